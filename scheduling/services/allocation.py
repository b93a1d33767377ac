"""Allocation: a due task goes to the best robot, which plans its remaining route anew.

Runs under the site's allocation lock (AllocationLock row), taken first and only here, so two
workers never allocate on one site at once. Then it locks the one chosen robot. Everything
else that changes a robot's route holds that robot's lock, so the chosen robot's route is
read again under its lock, and the plan is built on that.

settings.ALLOCATION_POLICY picks the rule: "multi" (the least added travel, the source paper's),
"delivery_time" (added travel plus the waiting it causes), or "single" (only robots holding no
task are candidates, as hospital fleets ran before the paper); see bench/fleet_day.py.
"""

import logging
from dataclasses import dataclass
from datetime import datetime, timedelta

from django.conf import settings
from django.db import transaction
from django.db.models import Case, IntegerField, Value, When
from django.utils import timezone

from robots.mapcache import router_for
from robots.models import Robot, Site
from robots.selectors import robots_for_allocation
from robots.services import robot_lock_if_available
from scheduling.allocator import (
    Stop,
    TaskStops,
    allocate,
    allocate_for_delivery_time,
    best_plan,
)
from scheduling.choices import Cause, Priority, TaskStatus
from scheduling.metrics import ALLOCATION_SECONDS
from scheduling.models import AllocationLock, Task, TaskStop
from scheduling.selectors import HeldRoute, robot_route, robot_routes, task_stops
from scheduling.services.history import allocation_enqueue, task_record
from scheduling.services.plans import plan_post

logger = logging.getLogger(__name__)

DUE_BATCH = 200  # tasks one due sweep allocates at most; the next sweep takes the rest
NO_ROBOT = "no robot available (online, not paused or in error, battery above the threshold)"
NO_SECURE_ROBOT = "secure: no available robot has a lockable compartment"
NO_ROUTE = "no available robot can fit it in its route (capacity or unreachable stops)"
NO_EMPTY_ROBOT = "no available robot is empty (single-task allocation)"


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
    the site's lock, so a burst of requests is still allocated one at a time by the worker.
    """
    try:
        with transaction.atomic():  # a savepoint: on failure the task stays created and due
            site = _allocation_lock(task.site_id, wait=False)
            if site is not None:
                _allocate(task, site, now, stops=stops)
                return
    except Exception:
        logger.exception("allocating new task %s failed; the worker tries again", task.code)
    allocation_enqueue(task.pk)


def due_sweep(*, now: datetime | None = None) -> int:
    """Tasks whose time came become due; every due task is offered to the robots, urgent
    ones first. Finds what a lost Celery message left behind. Returns how many were assigned."""
    now = now or timezone.now()
    for task_id in Task.objects.filter(
        status=TaskStatus.SCHEDULED, requested_time__lte=now
    ).values_list("pk", flat=True):
        task_make_due(task_id=task_id, now=now)
    due = (
        Task.objects.filter(status=TaskStatus.DUE, robot__isnull=True)
        .annotate(rank=_URGENT_FIRST)
        .order_by("rank", "requested_time", "pk")
        .values_list("pk", flat=True)[:DUE_BATCH]
    )
    return sum(_allocate_logging_errors(task_id, now) for task_id in list(due))


def _allocate_logging_errors(task_id: int, now: datetime) -> bool:
    """One task's failure (a deadlock victim, say) must not stop the sweep for the others."""
    try:
        return task_allocate(task_id=task_id, now=now)
    except Exception:
        logger.exception("allocating task %s failed; the next sweep tries again", task_id)
        return False


_URGENT_FIRST = Case(
    When(priority=Priority.URGENT, then=Value(0)), default=Value(1), output_field=IntegerField()
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


def _allocation_lock(site_id: int, *, wait: bool = True) -> Site | None:
    """Lock the site's allocation lock row for the rest of the transaction; return the site.

    Without `wait`, None if another transaction holds it.
    """
    locked = AllocationLock.objects.select_for_update(of=("self",), skip_locked=not wait)
    locked = locked.select_related("site").filter(site_id=site_id)
    lock = locked.first()
    if lock is None:  # held by another transaction, or the site's first allocation
        _, created = AllocationLock.objects.get_or_create(site_id=site_id)
        if created or wait:
            lock = locked.get()
    return lock.site if lock else None


@ALLOCATION_SECONDS.time()
def _allocate(task: Task, site: Site, now: datetime, stops: list[TaskStop] | None = None) -> bool:
    new = task_stops(task, task.stops.all() if stops is None else stops, site=site)
    routes = robot_routes(robots=robots_for_allocation(site=site))
    if task.secure:  # it travels locked: only robots that can lock it away
        routes = {pk: held for pk, held in routes.items() if held.robot.lockable_compartments}
        if not routes:
            _wait(task, NO_SECURE_ROBOT)
            return False
    while True:
        candidates = _candidates(routes)
        choice = _choose(new, task, candidates, router_for(site).travel_time)
        if choice is None:
            _wait(task, _why_not(routes, candidates))
            return False
        robot = robot_lock_if_available(choice.robot_id, site)
        if robot is not None:
            break
        # Paused, gone offline or in error since it was read: choose among the others.
        del routes[choice.robot_id]
    read = routes[choice.robot_id]
    held = robot_route(robot=robot)
    stops = choice.stops
    if held.signature != read.signature:  # its route changed since it was read: plan on the new
        plan = best_plan(held.route, router_for(site).travel_time, extra=new)
        if plan is None:
            _wait(task, NO_ROUTE)
            return False
        stops = plan.stops
    return _assign(task, robot, held, stops, now)


def _candidates(routes: dict[int, HeldRoute]) -> dict[int, HeldRoute]:
    """Robots that may take the task: all available ones ("multi": online multi-task
    allocation), or only those holding no task ("single": single-task allocation)."""
    if settings.ALLOCATION_POLICY == "single":
        return {pk: held for pk, held in routes.items() if held.is_empty}
    return routes


def _why_not(routes: dict[int, HeldRoute], candidates: dict[int, HeldRoute]) -> str:
    if not routes:
        return NO_ROBOT
    return NO_ROUTE if candidates else NO_EMPTY_ROBOT


@dataclass(frozen=True)
class _Choice:
    robot_id: int
    stops: tuple[Stop, ...]


def _choose(
    new: TaskStops, task: Task, routes: dict[int, HeldRoute], travel_time
) -> _Choice | None:
    """The best robot for the task; the robot that let it time out last only if no other can."""
    by_code = {held.route.robot: pk for pk, held in routes.items()}
    others = [h.route for pk, h in routes.items() if pk != task.timed_out_robot_id]
    rule = allocate_for_delivery_time if settings.ALLOCATION_POLICY == "delivery_time" else allocate
    allocation = rule(new, others, travel_time) if others else None
    if allocation is None and task.timed_out_robot_id in routes:
        allocation = rule(new, [routes[task.timed_out_robot_id].route], travel_time)
    if allocation is None:
        return None
    return _Choice(by_code[allocation.robot], allocation.plan.stops)


class _CancelledMeanwhile(Exception):
    """The task stopped being due while it was allocated: roll the allocation back."""


def _assign(task: Task, robot: Robot, held: HeldRoute, stops, now: datetime) -> bool:
    """Post the plan, then claim the task (raising _CancelledMeanwhile if that fails): the plan
    goes first because posting it wakes the robot, which travels while this commits."""
    ack_due_at = now + timedelta(seconds=robot.site.ack_timeout)
    fields = {"robot": robot, "assigned_at": now, "ack_due_at": ack_due_at, "waiting_reason": ""}
    tasks = {**held.tasks, task.code: task}
    plan_post(robot=robot, start=held.route.start, stops=stops, tasks=tasks, now=now)
    claimed = Task.objects.filter(pk=task.pk, status=TaskStatus.DUE, robot__isnull=True).update(
        status=TaskStatus.ASSIGNED, **fields
    )
    if not claimed:
        raise _CancelledMeanwhile(task.code)
    for name, value in fields.items():
        setattr(task, name, value)
    task.status = TaskStatus.ASSIGNED
    task_record(task, old=TaskStatus.DUE, at=now, cause=Cause.ALLOCATION, robot=robot)
    return True


def _wait(task: Task, reason: str) -> None:
    """Record why the task stays due (logged once per change of reason)."""
    if task.waiting_reason != reason:
        logger.info("%s stays due: %s", task.code, reason)
        Task.objects.filter(pk=task.pk).update(waiting_reason=reason)
