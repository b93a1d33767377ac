"""Allocation: a due task goes to the best robot, which plans its remaining route anew.

Runs under the site's allocation lock (AllocationLock row), taken first and only here, so two
workers never allocate on one site at once. Then it locks the one chosen robot. Everything
else that changes a robot's route holds that robot's lock, so the chosen robot's route is
read again under its lock, and the plan is built on that.

settings.ALLOCATION_POLICY picks the rule: "delivery_time" (added travel plus the waiting it
causes), "paper" (the source paper's: a standby robot first, the one reaching the pick-up
soonest, else the least added travel), "least_travel" (the least added travel, standby or not),
or "single" (only robots holding no task are candidates, as hospital fleets ran before the
paper); see bench/fleet_day.py.
"""

import logging
import statistics
from collections import Counter
from dataclasses import dataclass, replace
from datetime import datetime, timedelta

from django.conf import settings
from django.db import transaction
from django.db.models import Case, F, IntegerField, Value, When
from django.utils import timezone
from django.utils.translation import gettext_noop

from core import memo
from core.said import Said
from robots.mapcache import router_for
from robots.models import Robot, Site
from robots.selectors import robots_for_allocation
from robots.services import robot_lock_if_available
from scheduling.allocator import (
    Stop,
    TaskStops,
    allocate,
    allocate_for_delivery_time,
    allocate_standby_first,
    best_plan,
)
from scheduling.choices import PRIORITY_RANK, Cause, Priority, TaskStatus
from scheduling.deadlines import priority_said
from scheduling.metrics import ALLOCATION_SECONDS
from scheduling.models import AllocationLock, Task, TaskStop
from scheduling.selectors import HeldRoute, robot_route, robot_routes, task_stops
from scheduling.services.charging import robot_can_finish
from scheduling.services.etas import deadline_alert, etas_write, task_deadline_check
from scheduling.services.history import allocation_enqueue, task_record, tasks_record
from scheduling.services.plans import plan_post

logger = logging.getLogger(__name__)

DUE_BATCH = 200  # tasks one due sweep allocates at most; the next sweep takes the rest
NO_ROBOT = gettext_noop(
    "no robot available (online, not paused or in error, battery above the threshold)"
)
NO_SECURE_ROBOT = gettext_noop("secure: no available robot has a lockable compartment")
NO_ROUTE = gettext_noop(
    "no available robot can fit it in its route (capacity or unreachable stops)"
)
NO_SECURE_ROUTE = gettext_noop(
    "secure: no available robot has a lockable compartment free for it on its route "
    "(or the capacity, or its stops are unreachable)"
)
NO_EMPTY_ROBOT = gettext_noop("no available robot is empty (single-task allocation)")
NO_BATTERY = gettext_noop("no available robot has the battery to do it and get back to its dock")
HELD_BY_FIRE_ALARM = gettext_noop(
    "held: a fire alarm is in force; it is allocated at the all-clear"
)


def task_allocate(*, task_id: int, now: datetime | None = None) -> bool:
    """Allocate a task if it is still due and unassigned; False if it stays due.

    Idempotent: a task that is no longer due is left alone.
    """
    now = now or timezone.now()
    site_id = Task.objects.filter(pk=task_id).values_list("site_id", flat=True).first()
    if site_id is None:
        return False
    try:
        with transaction.atomic():
            site = _allocation_lock(site_id)
            task = Task.objects.filter(pk=task_id, status=TaskStatus.DUE, robot__isnull=True)
            task = task.first()
            return task is not None and _allocate(task, site, now)
    except _CancelledMeanwhile:
        return False


def task_allocate_created(*, task: Task, stops: list[TaskStop], now: datetime) -> None:
    """Allocate a task just created due, in the transaction that creates it, if no allocation
    is running on its site; else, or if this fails, the Celery worker allocates it after commit.

    The nurse's request then commits with its robot chosen and the plan posted: no worker
    round trip on the way from the request to the robot (bench/latency.py). It never waits for
    the site's lock: the rest of a burst of requests is allocated by the worker, in batches.
    """
    try:
        with transaction.atomic():  # a savepoint: on failure the task stays created and due
            site = _allocation_lock(task.site_id, wait=False)
            if site is not None:
                _allocate(task, site, now, stops=stops)
                return
    except Exception:
        logger.exception("allocating new task %s failed; the worker tries again", task.code)
    allocation_enqueue(task)


def site_allocate_due(*, site_id: int, now: datetime | None = None) -> int:
    """Allocate every due task of the site (DUE_BATCH at most) in one transaction under its
    lock: STAT first, then urgent, then routine, each by due time; returns how many were
    assigned.

    A burst of requests is allocated in one batch: the robots' routes are read once, each task
    is added to the route of the robot it goes to, and each robot given tasks is posted one
    plan with all its new tasks at the end. The robots are chosen on their routes as read,
    unlocked, and only then locked, each once, and their routes read again: a robot's heartbeat
    then waits for the batch's writes only, not for its choices too (bench/latency.py, a burst
    of 100). A chosen robot whose route changed meanwhile plans its new tasks on its route as
    it is now; if one is no longer available, or its new tasks no longer fit, the batch is
    undone and made again locking each robot as it is chosen. The Celery worker runs this
    for a task the request could not allocate itself; later messages of the same burst find
    nothing left.
    """
    now = now or timezone.now()
    with transaction.atomic(), memo.scope():  # a batch's tasks share reads (core.memo)
        site = _allocation_lock(site_id)
        tasks = _due_tasks(site_id)
        if not tasks:
            return 0
        if site.fire_alarm_since is not None:
            return _hold(tasks)
        try:
            with transaction.atomic():  # a savepoint: undone if a chosen robot changed meanwhile
                batch = _Batch(site, now, lock_late=True)
                assigned = sum(batch.add(task) for task in tasks)
                batch.lock_chosen()
                batch.post()
                return assigned
        except _ReadAgain:
            pass
        batch = _Batch(site, now)
        assigned = sum(batch.add(task) for task in _due_tasks(site_id))
        batch.post()
        return assigned


def _due_tasks(site_id: int) -> list[Task]:
    due = Task.objects.filter(site_id=site_id, status=TaskStatus.DUE, robot__isnull=True)
    due = due.annotate(rank=_PRIORITY_RANK).order_by("rank", "due_at", "requested_time", "pk")
    return list(due.prefetch_related("stops")[:DUE_BATCH])


class _ReadAgain(Exception):
    """A robot chosen on its unlocked route changed or became unavailable before it was locked."""


class _Batch:
    """Tasks allocated together: each robot's route grows in memory; plans are posted last."""

    def __init__(self, site: Site, now: datetime, *, lock_late: bool = False):
        self.site, self.now, self.lock_late = site, now, lock_late
        self.routes = robot_routes(robots=robots_for_allocation(site=site), now=now)
        self.read = dict(self.routes)  # as read, before this batch's tasks join them
        self.locked: dict[int, Robot] = {}
        self.start: dict[int, str] = {}
        self.stops: dict[int, tuple[Stop, ...]] = {}  # robots given tasks: their new route
        self.assigned: list[tuple[Task, Robot]] = []

    def add(self, task: Task) -> bool:
        new = task_stops(task, task.stops.all(), site=self.site, now=self.now)
        routes, short_of_battery = dict(self.routes), False
        if task.secure:  # it travels locked: only robots that can lock it away
            routes = {pk: held for pk, held in routes.items() if held.robot.lockable_compartments}
            if not routes:
                _wait(task, NO_SECURE_ROBOT)
                return False
        while True:
            candidates = _candidates(routes)
            choice = _choose(new, task, candidates, router_for(self.site).travel_time)
            if choice is None:
                _wait(task, NO_BATTERY if short_of_battery else _why_not(task, routes, candidates))
                return False
            read = routes[choice.robot_id]
            if not robot_can_finish(robot=read.robot, start=read.route.start, stops=choice.stops):
                short_of_battery = True
                del routes[choice.robot_id]
                continue
            if self._lock(choice.robot_id):
                break
            if choice.robot_id in self.routes:  # its route changed: choose again with it
                routes[choice.robot_id] = self.routes[choice.robot_id]
            else:  # no longer available: choose among the others
                del routes[choice.robot_id]
        return self._claim(task, new, choice)

    def _lock(self, robot_id: int) -> bool:
        """Lock a robot the first time it is chosen, and take its route as it is now."""
        if robot_id in self.locked:
            return True
        if self.lock_late:  # chosen on its route as read; locked by lock_chosen
            self.locked[robot_id] = self.routes[robot_id].robot
            self.start[robot_id] = self.routes[robot_id].route.start
            return True
        robot = robot_lock_if_available(robot_id, self.site)
        if robot is None:
            del self.routes[robot_id]
            return False
        held = robot_route(robot=robot, now=self.now)
        if held.signature != self.routes[robot_id].signature:
            self.routes[robot_id] = held  # changed since read: the next choice plans on this
            return False
        self.locked[robot_id] = robot
        self.start[robot_id] = held.route.start
        return True

    def _claim(self, task: Task, new: TaskStops, choice) -> bool:
        robot = self.locked[choice.robot_id]
        ack_due_at = self.now + timedelta(seconds=self.site.ack_timeout)
        if not _task_claim(task, robot, self.now, ack_due_at):  # cancelled meanwhile
            return False
        held = self.routes[choice.robot_id]
        route = replace(held.route, tasks=(*held.route.tasks, new))
        self.routes[choice.robot_id] = replace(
            held, route=route, tasks={**held.tasks, task.code: task}
        )
        self.stops[choice.robot_id] = choice.stops
        self.assigned.append((task, robot))
        return True

    def lock_chosen(self) -> None:
        """Lock the robots given tasks, in order; a robot whose route changed since it was read
        (it acked or progressed) plans its new tasks on its route as it is now. _ReadAgain if
        a robot is no longer available or its new tasks no longer fit."""
        for robot_id in sorted(self.stops):
            robot = robot_lock_if_available(robot_id, self.site)
            if robot is None:
                raise _ReadAgain(robot_id)
            # Its route as read is without the tasks this batch claimed for it: compare like
            # with like (with them, every chosen robot would look changed and plan them twice).
            claimed = [task.pk for task in self._added(robot_id).values()]
            held = robot_route(robot=robot, now=self.now, excluding=claimed)
            if held.signature != self.read[robot_id].signature:
                self._replan(robot, held)
            self.locked[robot_id] = robot

    def _replan(self, robot: Robot, held: HeldRoute) -> None:
        read = self.read[robot.pk]
        added = self.routes[robot.pk].route.tasks[len(read.route.tasks) :]
        route = replace(held.route, tasks=(*held.route.tasks, *added))
        plan = best_plan(route, router_for(self.site).travel_time)
        if plan is None or not robot_can_finish(robot=robot, start=route.start, stops=plan.stops):
            raise _ReadAgain(robot.pk)
        new = self._added(robot.pk)
        self.routes[robot.pk] = replace(held, route=route, tasks={**held.tasks, **new})
        self.stops[robot.pk], self.start[robot.pk] = plan.stops, route.start

    def _added(self, robot_id: int) -> dict[str, Task]:
        """The tasks this batch gave the robot, by code."""
        read = self.read[robot_id].tasks
        return {code: t for code, t in self.routes[robot_id].tasks.items() if code not in read}

    def post(self) -> None:
        """One plan per robot given tasks, then each task's history and deadline check; the
        robots are woken when the batch commits (plan_post); the tasks' ETAs are written in one
        statement."""
        etas_changed: list[Task] = []
        for robot_id, stops in self.stops.items():
            robot, held = self.locked[robot_id], self.routes[robot_id]
            # Woken on commit: woken at once, each robot's heartbeat would hold a web worker
            # waiting on its row until the batch's last plan is posted.
            plan_post(
                robot=robot,
                start=self.start[robot_id],
                stops=stops,
                tasks=held.tasks,
                now=self.now,
                wake_at_once=False,
                etas_changed=etas_changed,
            )
        etas_write(etas_changed)
        tasks_record(self.assigned, old=TaskStatus.DUE, at=self.now, cause=Cause.ALLOCATION)
        for task, robot in self.assigned:
            task_deadline_check(task=task, robot=robot)
        _tasks_given_count(Counter(robot.pk for _task, robot in self.assigned))


def due_sweep(*, now: datetime | None = None) -> int:
    """Tasks whose time came become due; every due task is offered to the robots, a batch per
    site (site_allocate_due): STAT first, then urgent, then routine, each by due time. Finds
    what a lost Celery message left behind. Returns how many were assigned."""
    now = now or timezone.now()
    for task_id in Task.objects.filter(
        status=TaskStatus.SCHEDULED, requested_time__lte=now
    ).values_list("pk", flat=True):
        task_make_due(task_id=task_id, now=now)
    due = Task.objects.filter(status=TaskStatus.DUE, robot__isnull=True)
    sites = sorted(set(due.values_list("site_id", flat=True)))
    return sum(_allocate_logging_errors(site_id, now) for site_id in sites)


def _allocate_logging_errors(site_id: int, now: datetime) -> int:
    """One site's failure (a deadlock victim, say) must not stop the sweep for the others."""
    try:
        return site_allocate_due(site_id=site_id, now=now)
    except Exception:
        logger.exception("allocating on site %s failed; the next sweep tries again", site_id)
        return 0


def task_allocate_with_its_site(*, task_id: int, now: datetime | None = None) -> int:
    """The worker's allocation of a task the request left due: a batch of every due task of
    its site (site_allocate_due); returns how many were assigned."""
    site_id = Task.objects.filter(pk=task_id).values_list("site_id", flat=True).first()
    return 0 if site_id is None else site_allocate_due(site_id=site_id, now=now)


_PRIORITY_RANK = Case(
    *(When(priority=name, then=Value(rank)) for name, rank in PRIORITY_RANK.items()),
    default=Value(len(PRIORITY_RANK)),
    output_field=IntegerField(),
)


@transaction.atomic
def task_make_due(*, task_id: int, now: datetime) -> bool:
    """A scheduled task whose requested time came becomes due (claimed by conditional update)."""
    claimed = Task.objects.filter(pk=task_id, status=TaskStatus.SCHEDULED).update(
        status=TaskStatus.DUE
    )
    if claimed:
        task = Task.objects.get(pk=task_id)
        task_record(task, old=TaskStatus.SCHEDULED, at=now, cause=Cause.SWEEP)
    return bool(claimed)


def allocation_lock_take(site_id: int) -> Site:
    """Hold the site's allocation lock for the rest of the transaction, so that no allocation
    plans on the site's map meanwhile (a map being published: maps.services)."""
    return _allocation_lock(site_id)


def _allocation_lock(site_id: int, *, wait: bool = True) -> Site | None:
    """Lock the site's allocation lock row for the rest of the transaction; return the site.

    Without `wait`, None if another transaction holds it.
    """
    lock = _lock_row(site_id, wait=wait)
    if lock is None:  # held by another transaction, or the site's first allocation
        _, created = AllocationLock.objects.get_or_create(site_id=site_id)
        if created or wait:
            lock = _lock_row(site_id, wait=True)  # this transaction's own row: not skipped
    return lock.site if lock else None


def _lock_row(site_id: int, *, wait: bool) -> AllocationLock | None:
    locked = AllocationLock.objects.select_for_update(of=("self",), skip_locked=not wait)
    return next(iter(locked.select_related("site").filter(site_id=site_id)[:1]), None)


@ALLOCATION_SECONDS.time()
def _allocate(task: Task, site: Site, now: datetime, stops: list[TaskStop] | None = None) -> bool:
    if site.fire_alarm_since is not None:
        return _hold([task])
    new = task_stops(task, task.stops.all() if stops is None else stops, site=site, now=now)
    routes = robot_routes(robots=robots_for_allocation(site=site), now=now)
    if task.secure:  # it travels locked: only robots that can lock it away
        routes = {pk: held for pk, held in routes.items() if held.robot.lockable_compartments}
        if not routes:
            _wait(task, NO_SECURE_ROBOT)
            return False
    short_of_battery = False
    while True:
        candidates = _candidates(routes)
        choice = _choose(new, task, candidates, router_for(site).travel_time)
        if choice is None:
            _wait(task, NO_BATTERY if short_of_battery else _why_not(task, routes, candidates))
            return False
        read = routes[choice.robot_id]
        if not robot_can_finish(robot=read.robot, start=read.route.start, stops=choice.stops):
            short_of_battery = True  # it would not be back at its dock with the reserve left
            del routes[choice.robot_id]
            continue
        robot = robot_lock_if_available(choice.robot_id, site)
        if robot is not None:
            break
        # Paused, gone offline or in error since it was read: choose among the others.
        del routes[choice.robot_id]
    read = routes[choice.robot_id]
    held = robot_route(robot=robot, now=now)
    stops = choice.stops
    if held.signature != read.signature:  # its route changed since it was read: plan on the new
        plan = best_plan(held.route, router_for(site).travel_time, extra=new)
        if plan is None:
            _wait(task, NO_ROUTE)
            return False
        stops = plan.stops
    return _assign(task, robot, held, stops, now)


def _candidates(routes: dict[int, HeldRoute]) -> dict[int, HeldRoute]:
    """Robots that may take the task: all available ones (online multi-task allocation), or
    only those holding no task ("single": single-task allocation)."""
    if settings.ALLOCATION_POLICY == "single":
        return {pk: held for pk, held in routes.items() if held.is_empty}
    return routes


def _tasks_given_count(given: dict[int, int]) -> None:
    """Count the tasks just given to each robot (Robot.tasks_given, the allocator's tie-break);
    the robots' rows are locked by the allocation."""
    for robot_id, count in given.items():
        Robot.objects.filter(pk=robot_id).update(tasks_given=F("tasks_given") + count)


def _at_fleet_pace(routes: dict[int, HeldRoute]):
    """The routes compared at one pace, the median of those the robots have learned: a pace is
    learned only by a robot that travels, so the first robot to learn one (much faster than
    the map's estimate, as in a sped-up simulation) would look faster than every other robot
    and be given every delivery, and the others would never learn theirs."""
    learned = [held.robot.pace_travel for held in routes.values()]
    learned = [pace for pace in learned if pace is not None]
    if not learned:
        return {pk: held.route for pk, held in routes.items()}
    pace = statistics.median(learned)
    return {pk: replace(held.route, pace=pace) for pk, held in routes.items()}


def _why_not(task: Task, routes: dict[int, HeldRoute], candidates: dict[int, HeldRoute]) -> str:
    if not routes:
        return NO_ROBOT
    if not candidates:
        return NO_EMPTY_ROBOT
    return NO_SECURE_ROUTE if task.secure else NO_ROUTE


# settings.ALLOCATION_POLICY -> the allocator's rule for choosing among the candidates.
RULES = {
    "delivery_time": allocate_for_delivery_time,
    "paper": allocate_standby_first,
    "least_travel": allocate,
    "single": allocate,  # every candidate is empty: the least added travel is the nearest
}


@dataclass(frozen=True)
class _Choice:
    robot_id: int
    stops: tuple[Stop, ...]


def _choose(
    new: TaskStops, task: Task, routes: dict[int, HeldRoute], travel_time
) -> _Choice | None:
    """The best robot for the task; the robot that let it time out last only if no other can."""
    by_code = {held.route.robot: pk for pk, held in routes.items()}
    compared = _at_fleet_pace(routes)
    others = [route for pk, route in compared.items() if pk != task.timed_out_robot_id]
    rule = RULES[settings.ALLOCATION_POLICY]
    allocation = rule(new, others, travel_time) if others else None
    if allocation is None and task.timed_out_robot_id in routes:
        allocation = rule(new, [compared[task.timed_out_robot_id]], travel_time)
    if allocation is None:
        return None
    return _Choice(by_code[allocation.robot], allocation.plan.stops)


class _CancelledMeanwhile(Exception):
    """The task stopped being due while it was allocated: roll the allocation back."""


def _assign(task: Task, robot: Robot, held: HeldRoute, stops, now: datetime) -> bool:
    """Post the plan, then claim the task (raising _CancelledMeanwhile if that fails): the plan
    goes first because posting it wakes the robot, which travels while this commits."""
    ack_due_at = now + timedelta(seconds=robot.site.ack_timeout)
    tasks = {**held.tasks, task.code: task}
    plan_post(robot=robot, start=held.route.start, stops=stops, tasks=tasks, now=now)
    if not _task_claim(task, robot, now, ack_due_at):
        raise _CancelledMeanwhile(task.code)
    task_record(task, old=TaskStatus.DUE, at=now, cause=Cause.ALLOCATION, robot=robot)
    task_deadline_check(task=task, robot=robot)
    _tasks_given_count({robot.pk: 1})
    return True


def _task_claim(task: Task, robot: Robot, now: datetime, ack_due_at: datetime) -> bool:
    """Assign the task to the robot if it is still due and unassigned (its row claimed by a
    conditional update); else leave it as it was and return False."""
    claimed = {"robot": robot, "assigned_at": now, "ack_due_at": ack_due_at}
    claimed |= {"status": TaskStatus.ASSIGNED, "waiting_reason": ""}
    was = {name: getattr(task, name) for name in claimed}
    for name, value in claimed.items():
        setattr(task, name, value)
    unclaimed = Task.objects.filter(pk=task.pk, status=TaskStatus.DUE, robot=None)
    if unclaimed.update(**claimed):
        return True
    for name, value in was.items():
        setattr(task, name, value)
    return False


def _hold(tasks: list[Task]) -> int:
    """Nothing is planned while a fire alarm is in force: the tasks stay due, in their order,
    saying why (no deadline alert: operators already see the alarm). Returns 0 (assigned)."""
    held = [task.pk for task in tasks if task.waiting_reason != HELD_BY_FIRE_ALARM]
    if held:
        Task.objects.filter(pk__in=held).update(waiting_reason=HELD_BY_FIRE_ALARM)
    for task in tasks:
        task.waiting_reason = HELD_BY_FIRE_ALARM
    return 0


def _wait(task: Task, reason: str) -> None:
    """Record why the task stays due (logged once per change of reason); a STAT or urgent task
    that no robot takes is an operator's concern at once."""
    if task.waiting_reason == reason:
        return
    logger.info("%s stays due: %s", task.code, reason)
    Task.objects.filter(pk=task.pk).update(waiting_reason=reason)
    task.waiting_reason = reason
    if task.priority != Priority.ROUTINE:
        due = (
            Said(gettext_noop(", due %(time)s"), time=f"{timezone.localtime(task.due_at):%H:%M}")
            if task.due_at
            else ""
        )
        message = Said(
            gettext_noop("%(priority)s %(code)s has no robot%(due)s: %(reason)s"),
            priority=priority_said(task.priority),
            code=task.code,
            due=due,
            reason=Said(reason),
        )
        deadline_alert(task, message)
