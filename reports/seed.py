"""A generated history for the reports and their benchmark (manage.py reports_seed).

Deliveries spread over the days before `end` with a hospital's daily rhythm (a morning peak,
rounds, quiet nights), each with its stops, its full history of transitions, and an elevator
or door lease; each robot's activity as an unbroken timeline; some alerts. Deterministic for a
seed. Written with bulk inserts: rows as the services would have left them, not through them
(a year of heartbeats would take a year).
"""

import random
from dataclasses import dataclass
from datetime import datetime, timedelta

from django.db import transaction
from django.utils import timezone

from reports.models import DailyRollup
from resources.choices import LeaseEndCause, LeaseState
from resources.models import Lease
from robots.choices import WaypointKind
from robots.models import Alert, AlertKind, Resource, Robot, RobotActivity, Site, Waypoint
from scheduling.choices import Cause, StopAction, TaskStatus
from scheduling.deadlines import due_at_default
from scheduling.models import Task, TaskStop, TaskTransition

BATCH = 5000
# Relative request rate by hour of day (local time): peaks at 9-11 and 14-16, little at night.
HOURLY = [1, 1, 1, 1, 1, 2, 4, 8, 12, 14, 13, 10, 8, 10, 12, 12, 10, 8, 6, 4, 3, 2, 1, 1]
PRIORITIES = [("routine", 0.8), ("urgent", 0.2)]
# (activity, minutes low, high, weight) of each stretch of a robot's day
ACTIVITIES = [
    ("moving", 2, 8, 30),
    ("waiting_resource", 0.2, 3, 10),
    ("in_resource", 0.5, 2, 8),
    ("waiting_load", 0.5, 3, 8),
    ("waiting_unload", 0.5, 3, 8),
    ("idle", 2, 30, 25),
    ("charging", 20, 60, 5),
    ("unreachable", 0.1, 1, 4),
    ("offline", 5, 30, 1),
    ("error", 1, 10, 1),
]


@dataclass
class Seeded:
    deliveries: int
    transitions: int
    activities: int
    leases: int
    alerts: int


def history_seed(*, site: Site, deliveries: int, days: int, end: datetime, seed: int = 1) -> Seeded:
    """Add `deliveries` deliveries requested over the `days` days before `end`."""
    rng = random.Random(seed)
    robots = list(Robot.objects.filter(site=site).order_by("code"))
    stations = list(Waypoint.objects.filter(site=site, kind=WaypointKind.STATION))
    resources = list(Resource.objects.filter(site=site))
    if not robots or len(stations) < 2:
        raise ValueError(f"site {site.code} needs robots and at least two stations")
    start = end - timedelta(days=days)
    with transaction.atomic():
        # The days it writes into are no longer what their stored figures say.
        DailyRollup.objects.filter(site=site, day__gte=timezone.localdate(start)).delete()
        tasks = _tasks(rng, site, robots, stations, start, end, deliveries)
        transitions = _histories(tasks)
        leases = _leases(rng, tasks, resources)
        activities = sum(_activity(rng, robot, start, end) for robot in robots)
        alerts = _alerts(rng, site, robots, start, end, max(deliveries // 200, 1))
    return Seeded(len(tasks), transitions, activities, leases, alerts)


def _request_times(rng: random.Random, start: datetime, end: datetime, n: int) -> list[datetime]:
    """`n` times within [start, end), each day shaped by HOURLY (site local time)."""
    first = timezone.localtime(start).replace(hour=0, minute=0, second=0, microsecond=0)
    days = (end - first).days + 1
    times = []
    while len(times) < n:
        hour = rng.choices(range(24), weights=HOURLY)[0]
        offset = timedelta(days=rng.randrange(days), hours=hour, seconds=rng.uniform(0, 3600))
        at = first + offset
        if start <= at < end:
            times.append(at)
    return sorted(times)


def _tasks(rng, site, robots, stations, start, end, n) -> list[Task]:
    tasks, stops = [], []
    names, weights = zip(*PRIORITIES, strict=True)
    for requested in _request_times(rng, start, end, n):
        tasks.append(
            _task(rng, site, rng.choice(robots), requested, rng.choices(names, weights)[0])
        )
    Task.objects.bulk_create(tasks, batch_size=BATCH)
    for task in tasks:
        pickup, dropoff = rng.sample(stations, 2)
        for index, (action, waypoint, change, done) in enumerate(
            [
                (StopAction.PICKUP, pickup, 1, task.picked_up_at),
                (StopAction.DROPOFF, dropoff, -1, task.delivered_at),
            ]
        ):
            stops.append(
                TaskStop(
                    task=task,
                    index=index,
                    action=action,
                    waypoint=waypoint,
                    load_change=change,
                    done_at=done,
                    skipped_at=None if done or task.status != TaskStatus.CANCELLED else done,
                )
            )
    TaskStop.objects.bulk_create(stops, batch_size=BATCH)
    return tasks


def _task(rng, site, robot, requested: datetime, priority: str) -> Task:
    hurry = 0.6 if priority == "urgent" else 1.0
    assigned = requested + timedelta(seconds=rng.uniform(0.05, 2))
    acknowledged = assigned + timedelta(seconds=rng.uniform(0.5, 3))
    picked_up = acknowledged + timedelta(minutes=rng.lognormvariate(1.2, 0.6) * hurry)
    delivered = picked_up + timedelta(minutes=rng.lognormvariate(1.6, 0.5) * hurry)
    fate = rng.random()
    task = Task(
        site=site,
        sender="Generated",
        receiver="Generated",
        contents="Samples",
        priority=priority,
        requested_time=requested,
        created_at=requested,
        robot=robot,
        assigned_at=assigned,
        acknowledged_at=acknowledged,
        due_at=due_at_default(site=site, priority=priority, requested_time=requested),
    )
    if fate < 0.02:  # cancelled before pick-up
        task.status, task.cancelled_at = TaskStatus.CANCELLED, acknowledged + timedelta(minutes=1)
    elif fate < 0.03:  # failed on the way
        task.status, task.picked_up_at = TaskStatus.FAILED, picked_up
        task.failed_at = picked_up + timedelta(minutes=2)
    else:
        task.status = TaskStatus.COMPLETED
        task.picked_up_at, task.delivered_at = picked_up, delivered
        task.completed_at = delivered + timedelta(seconds=rng.uniform(5, 30))
    return task


def _histories(tasks: list[Task]) -> int:
    rows = []
    for task in tasks:
        steps = [
            ("", TaskStatus.DUE, task.requested_time, Cause.REQUEST),
            (TaskStatus.DUE, TaskStatus.ASSIGNED, task.assigned_at, Cause.ALLOCATION),
            (TaskStatus.ASSIGNED, TaskStatus.ACKNOWLEDGED, task.acknowledged_at, Cause.ROBOT_ACK),
        ]
        if task.status == TaskStatus.CANCELLED:
            steps.append(
                (TaskStatus.ACKNOWLEDGED, TaskStatus.CANCELLED, task.cancelled_at, Cause.USER)
            )
        else:
            steps.append(
                (
                    TaskStatus.ACKNOWLEDGED,
                    TaskStatus.PICKED_UP,
                    task.picked_up_at,
                    Cause.ROBOT_EVENT,
                )
            )
        if task.status == TaskStatus.FAILED:
            steps.append(
                (TaskStatus.PICKED_UP, TaskStatus.FAILED, task.failed_at, Cause.ROBOT_EVENT)
            )
        elif task.status == TaskStatus.COMPLETED:
            steps += [
                (TaskStatus.PICKED_UP, TaskStatus.DELIVERED, task.delivered_at, Cause.ROBOT_EVENT),
                (TaskStatus.DELIVERED, TaskStatus.COMPLETED, task.completed_at, Cause.ROBOT_EVENT),
            ]
        rows += [
            TaskTransition(task=task, at=at, old=old, new=new, cause=cause, robot=task.robot)
            for old, new, at, cause in steps
        ]
    TaskTransition.objects.bulk_create(rows, batch_size=BATCH)
    return len(rows)


def _leases(rng, tasks: list[Task], resources: list[Resource]) -> int:
    if not resources:
        return 0
    rows = []
    for task in tasks:
        if task.picked_up_at is None:
            continue
        resource = rng.choice(resources)
        requested = task.picked_up_at + timedelta(seconds=rng.uniform(10, 60))
        granted = requested + timedelta(seconds=rng.expovariate(1 / 20))
        entered = granted + timedelta(seconds=rng.uniform(2, 10))
        rows.append(
            Lease(
                resource=resource,
                robot=task.robot,
                request_id=f"seed-{task.pk}",
                state=LeaseState.RELEASED,
                requested_at=requested,
                granted_at=granted,
                expires_at=granted + timedelta(seconds=60),
                entered_at=entered,
                ended_at=entered + timedelta(seconds=rng.uniform(20, 90)),
                end_cause=LeaseEndCause.RELEASED_EVENT,
            )
        )
    Lease.objects.bulk_create(rows, batch_size=BATCH)
    return len(rows)


def _activity(rng, robot: Robot, start: datetime, end: datetime) -> int:
    names = [a[0] for a in ACTIVITIES]
    weights = [a[3] for a in ACTIVITIES]
    spans = {a[0]: (a[1], a[2]) for a in ACTIVITIES}
    rows, at, previous = [], start, None
    while at < end:
        activity = rng.choices(names, weights)[0]
        if activity == previous:
            continue
        rows.append(RobotActivity(robot=robot, at=at, activity=activity))
        low, high = spans[activity]
        at += timedelta(minutes=rng.uniform(low, high))
        previous = activity
    RobotActivity.objects.bulk_create(rows, batch_size=BATCH)
    return len(rows)


def _alerts(rng, site, robots, start, end, n) -> int:
    kinds = [AlertKind.TASK_FAILED, AlertKind.OFFLINE_WITH_LOAD, AlertKind.ROBOT_ERROR]
    seconds = (end - start).total_seconds()
    rows = []
    for number in range(n):
        raised = start + timedelta(seconds=rng.uniform(0, seconds))
        rows.append(
            Alert(
                site=site,
                kind=rng.choice(kinds),
                key=f"seed-{site.pk}-{number}-{rng.getrandbits(32)}",
                message="generated",
                robot=rng.choice(robots),
                raised_at=raised,
                acknowledged_at=raised + timedelta(minutes=5),
            )
        )
    Alert.objects.bulk_create(rows, batch_size=BATCH)
    return len(rows)
