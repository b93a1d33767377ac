"""ETAs that come true: each task's pick-up and drop-off time along its robot's plan.

A plan's ETAs are set when it is posted (plans.plan_post) and recomputed whenever its robot
reports progress (an `arrived`, `loaded`, `unloaded` or `task_completed` event), from where the
robot is now, through the stops before each task's, counting:

* the travel by the map, times the robot's own pace (Robot.pace_travel: what its travel took
  over what the map said, learned from its events on legs it drove from one stop to the next
  of tasks it already held: the time between its last stop and a task it was given later is
  idling and going home, not travel);
* the time it spends at each stop (Robot.pace_dwell, learned likewise; until then the site's
  stop_dwell_seconds);
* on its next leg, the wait for each elevator, door or corridor it does not hold yet, by the
  lease queue as it is now (resources.leases.resource_wait_estimate). Further legs have no
  queue to read yet: the learned pace carries the typical wait.

Learning reads the robot's own clock (the events' `at`), so a robot that runs twenty times
faster than real ones (the demo) is predicted twenty times faster, without the server knowing.
"""

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta

from django.db.models import Q
from django.utils.translation import gettext_noop

from boards.choices import EventType
from boards.models import RobotEvent
from boards.services import AppliedHeartbeat
from core import changes
from core.said import Said
from resources.choices import HOLDING_LEASE_STATES
from resources.leases import resource_wait_estimate
from resources.models import Lease, Resource
from robots.alerts import alert_raise
from robots.mapcache import router_for, site_map
from robots.models import AlertKind, Robot
from robots.router import Router
from robots.selectors import waypoint_code
from scheduling.allocator import PICKUP, Stop
from scheduling.deadlines import lateness_said, priority_said
from scheduling.models import RobotPlan, Task, TaskStop
from scheduling.models.tasks import task_code, task_pk
from scheduling.selectors import robot_pace, robot_route

LEARNING_RATE = 0.2  # weight of each new observation in the running average
PACE_LIMITS = (0.02, 50.0)  # a ratio outside these is a glitch, not a pace
LONGEST_OBSERVATION = timedelta(hours=1)  # longer gaps are pauses, not travel or dwell
PROGRESS_EVENTS = {
    EventType.ARRIVED,
    EventType.LOADED,
    EventType.UNLOADED,
    EventType.TASK_COMPLETED,
}
DONE_EVENTS = (EventType.LOADED, EventType.UNLOADED)


@dataclass(frozen=True)
class StopTime:
    stop: Stop
    arrive: float  # seconds from now
    done: float


def stop_times(
    router: Router,
    start: str,
    stops: Sequence[Stop],
    *,
    pace: float = 1.0,
    dwell: float = 0.0,
    first_wait: float = 0.0,
) -> list[StopTime]:
    """When the robot reaches and leaves each stop, in seconds from now; `first_wait` is spent
    on the first leg that moves it (waiting for the resources on it)."""
    times, here, clock, wait = [], start, 0.0, first_wait
    for stop in stops:
        if stop.place != here:
            clock += wait + router.travel_time(here, stop.place) * pace
            wait = 0.0
        times.append(StopTime(stop, clock, clock + dwell))
        clock += dwell
        here = stop.place
    return times


def task_deadline_check(*, task: Task, robot: Robot | None = None) -> bool:
    """Alert operators if the task's ETA is after its due-by time; True if it is."""
    late = lateness_said(eta=task.eta, due_at=task.due_at)
    if late:
        message = Said(
            gettext_noop("%(priority)s %(code)s%(who)s: %(lateness)s"),
            priority=priority_said(task.priority),
            code=task.code,
            who=f" ({robot.code})" if robot else "",
            lateness=late,
        )
        deadline_alert(task, message, robot)
    return late is not None


def deadline_alert(task: Task, message: str | Said, robot: Robot | None = None) -> None:
    """One open alert per task whose deadline is at risk (raising it again changes nothing)."""
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.DEADLINE_AT_RISK,
        key=f"deadline:{task.code}",
        message=message,
        robot=robot,
        task=task.code,
    )


def etas_store(tasks: dict[str, Task], times: Iterable[StopTime], now: datetime) -> list[Task]:
    """Each task's drop-off ETA (when its last stop is done) and pick-up ETA (when the robot
    reaches its first pick-up still to do; none once picked up). Returns the tasks whose ETAs
    changed."""
    changed = etas_set(tasks, times, now)
    etas_write(changed)
    return changed


def etas_set(tasks: dict[str, Task], times: Iterable[StopTime], now: datetime) -> list[Task]:
    """etas_store's ETAs, set on the tasks but not written (etas_write); the tasks whose ETAs
    changed."""
    done, pickup = {}, {}
    for time in times:
        done[time.stop.task] = time.done
        if time.stop.action == PICKUP:
            pickup.setdefault(time.stop.task, time.arrive)
    changed = []
    for code, seconds in done.items():
        task = tasks[code]
        before = (task.eta, task.pickup_eta)
        task.eta = _at(now, seconds)
        task.pickup_eta = _at(now, pickup[code]) if code in pickup else None
        if (task.eta, task.pickup_eta) != before:
            changed.append(task)
    return changed


def etas_write(tasks: list[Task]) -> None:
    """Write the tasks' ETAs, in one statement however many; no query for none."""
    if len(tasks) == 1:  # a lone request allocated in the request: a plain UPDATE, not a CASE
        task = tasks[0]
        Task.objects.filter(pk=task.pk).update(eta=task.eta, pickup_eta=task.pickup_eta)
        return
    Task.objects.bulk_update(tasks, ["eta", "pickup_eta"])


def _at(now: datetime, seconds: float) -> datetime | None:
    return now + timedelta(seconds=seconds) if math.isfinite(seconds) else None


# --- On progress --------------------------------------------------------------------------------


def heartbeat_progress(*, applied: AppliedHeartbeat) -> None:
    """Learn from the heartbeat's progress events, then recompute the robot's ETAs.

    Inside the heartbeat's transaction, robot row locked; a heartbeat without progress events
    (nearly all of them) costs nothing here."""
    events = [e for e in applied.events if e.type in PROGRESS_EVENTS and e.task]
    if not events:
        return
    robot_pace_learn(robot=applied.robot, events=events)
    robot_etas_refresh(robot=applied.robot, now=applied.now)


def robot_etas_refresh(*, robot: Robot, now: datetime) -> int:
    """Recompute the ETAs of the tasks on the robot's route along its current plan; returns
    how many tasks were estimated. Late ones alert operators (task_deadline_check); changed ones
    go to the pages (core.changes ETAS)."""
    held = robot_route(robot=robot, now=now)
    if held.is_empty:
        return 0
    remaining = [stop for task in held.route.tasks for stop in (*task.pickups, *task.dropoffs)]
    stops = _plan_order(robot, remaining)
    router, start = router_for(robot.site), held.route.start
    going = next((stop.place for stop in stops if stop.place != start), None)
    first_wait = _first_leg_wait(robot, router, start, going, now) if going else 0.0
    pace, dwell = robot_pace(robot)
    times = stop_times(router, start, stops, pace=pace, dwell=dwell, first_wait=first_wait)
    changed = etas_store(held.tasks, times, now)
    if changed:  # the requesters' pages show them at once (ui/live)
        changes.changed(kind=changes.ETAS, site_id=robot.site_id, subject=changed)
    for code in dict.fromkeys(time.stop.task for time in times):
        task_deadline_check(task=held.tasks[code], robot=robot)
    return len(held.tasks)


def _plan_order(robot: Robot, remaining: list[Stop]) -> list[Stop]:
    """The remaining stops in the order of the robot's current plan (any the plan lacks last)."""
    plan = RobotPlan.objects.filter(robot=robot).only("body").first()
    order = {}
    for n, stop in enumerate(plan.body.get("stops", []) if plan else []):
        order.setdefault((stop.get("task"), stop.get("stop")), n)
    return sorted(remaining, key=lambda s: order.get((s.task, s.index), math.inf))


def _first_leg_wait(robot: Robot, router: Router, start: str, place: str, now: datetime) -> float:
    """The lease queues' wait on the robot's next leg (from `start` to `place`), for the
    resources it does not hold.

    One query for the live leases of every resource on the leg (the resources themselves come
    from the site's cached map): a resource nobody holds or waits for has no wait, which is
    what resource_wait_estimate would say after its own queries; it is asked only about the
    busy ones the robot does not hold."""
    codes = router.leg(start, place).resources
    if not codes:
        return 0.0
    resources = site_map(robot.site).resources
    ids = [resources[code].id for code in codes if code in resources]
    live = Lease.objects.live().filter(resource_id__in=ids)
    busy, held = set(), set()
    for resource_id, robot_id, state in live.values_list("resource_id", "robot_id", "state"):
        busy.add(resource_id)
        if robot_id == robot.pk and state in HOLDING_LEASE_STATES:
            held.add(resource_id)
    busy -= held
    if not busy:
        return 0.0
    return sum(
        resource_wait_estimate(resource=resource, now=now)
        for resource in Resource.objects.filter(pk__in=busy).order_by("pk")
    )


# --- Learning -----------------------------------------------------------------------------------


def robot_pace_learn(*, robot: Robot, events: list[RobotEvent]) -> None:
    """Update the robot's pace from its `arrived` (travel since its last stop was done) and its
    `loaded`/`unloaded` events (dwell since it arrived there)."""
    changed = []
    done = [e for e in events if e.type in DONE_EVENTS and e.task and e.stop is not None]
    arrivals = _arrivals(robot, done)
    for event in events:
        if event.type == EventType.ARRIVED and event.task and event.stop is not None:
            changed += _travel_learn(robot, event)
        elif event in done:
            changed += _dwell_learn(robot, event, arrivals)
    if changed:
        robot.save(update_fields=sorted(set(changed)))


def _travel_learn(robot: Robot, event: RobotEvent) -> list[str]:
    before = (
        RobotEvent.objects.filter(robot=robot, type__in=DONE_EVENTS, id__lt=event.id)
        .exclude(task="")
        .order_by("-id")
        .first()
    )
    seconds = _between(before, event)
    if seconds is None or _given_after(robot, event.task, before):
        return []
    places = _places(robot, [(before.task, before.stop), (event.task, event.stop)])
    if len(places) != 2 or places[0] == places[1]:
        return []
    predicted = router_for(robot.site).travel_time(*places)
    if not 0 < predicted < math.inf:
        return []
    ratio = min(max(seconds / predicted, PACE_LIMITS[0]), PACE_LIMITS[1])
    robot.pace_travel = _averaged(robot.pace_travel, ratio)
    return ["pace_travel"]


def _given_after(robot: Robot, code: str, done: RobotEvent) -> bool:
    """Whether the robot was given the task after it reported `done`: it then did not drive
    from that stop to this one all along (it went back to its dock, or waited there), and the
    time between the two events is not travel. Both times by the server's clock."""
    assigned_at = (
        Task.objects.filter(pk=task_pk(code), robot=robot)
        .values_list("assigned_at", flat=True)
        .first()
    )
    return assigned_at is None or assigned_at > done.received_at


def _arrivals(robot: Robot, done: list[RobotEvent]) -> list[RobotEvent]:
    """The robot's `arrived` events at the stops of `done` (loaded, unloaded) before them,
    newest first: one query per task (a delivery reported at once has two stops of one)."""
    before = max((event.id for event in done), default=0)
    stops = {(event.task, event.stop) for event in done}
    found = [
        arrived
        for code in sorted({event.task for event in done})
        for arrived in RobotEvent.objects.filter(
            robot_id=robot.pk, type=EventType.ARRIVED, task=code, id__lt=before
        )
        if (arrived.task, arrived.stop) in stops
    ]
    return sorted(found, key=lambda event: -event.id)


def _dwell_learn(robot: Robot, event: RobotEvent, arrivals: list[RobotEvent]) -> list[str]:
    arrived = next(
        (a for a in arrivals if (a.task, a.stop) == (event.task, event.stop) and a.id < event.id),
        None,
    )
    seconds = _between(arrived, event)
    if seconds is None:
        return []
    robot.pace_dwell = _averaged(robot.pace_dwell, seconds)
    return ["pace_dwell"]


def _between(earlier: RobotEvent | None, later: RobotEvent) -> float | None:
    """Seconds between two events by the robot's clock (else by when they reached us)."""
    if earlier is None:
        return None
    if earlier.at and later.at:
        gap = later.at - earlier.at
    else:
        gap = later.received_at - earlier.received_at
    return gap.total_seconds() if timedelta(0) <= gap <= LONGEST_OBSERVATION else None


def _places(robot: Robot, stops: list[tuple[str, int]]) -> list[str]:
    """The waypoint codes of (task code, stop index) pairs, in order; one query."""
    wanted = Q()
    for code, index in stops:
        wanted |= Q(task_id=task_pk(code), index=index)
    rows = TaskStop.objects.filter(wanted).values_list("task_id", "index", "waypoint_id")
    found = {(task_code(task_id), index): waypoint for task_id, index, waypoint in rows}
    return [waypoint_code(robot.site, found[key]) for key in stops if key in found]


def _averaged(old: float | None, new: float) -> float:
    return new if old is None else (1 - LEARNING_RATE) * old + LEARNING_RATE * new
