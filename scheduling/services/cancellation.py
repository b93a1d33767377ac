"""Cancellation by a user, in the three cases of protocol v1 ("Cancellation")."""

from datetime import datetime

from django.db import transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from audit.choices import Kind
from audit.services import entry_record
from core.said import Said
from robots.services import robot_lock
from scheduling.choices import FINISHED_STATUSES, WAITING_STATUSES, Cause, StopAction, TaskStatus
from scheduling.models import Task, TaskStop
from scheduling.services.history import task_move, task_record
from scheduling.services.plans import plan_withdraw_pending, robot_replan

ATTEMPTS = 5  # a waiting task may be assigned while being cancelled; then try again


class TaskNotCancellable(Exception):
    """The task is delivered, finished, or already on its way back."""


class TaskChanged(Exception):
    """The task's history grew past the entries the caller had seen (a FHIR If-Match)."""


class _Moved(Exception):
    """The task changed hands while we were locking; start again."""


def task_cancel(
    *, task: Task, by, now: datetime | None = None, history_count: int | None = None
) -> Task:
    """Cancel a task for user `by`.

    Not yet with a robot: cancelled. Assigned, not acknowledged: its plan is withdrawn and a
    corrected plan posted. Acknowledged, nothing on board: a new plan without it. Items on
    board: a return trip to its (first) pick-up point. Raises TaskNotCancellable otherwise.

    With `history_count`, only if the task's history still has that many entries (checked with
    the task held as for the change itself), else TaskChanged: the caller decided on an older
    state.
    """
    now = now or timezone.now()
    for _ in range(ATTEMPTS):
        try:
            with transaction.atomic():
                return _cancel(task.pk, by, now, history_count)
        except _Moved:
            continue
    raise TaskNotCancellable(f"{task.code} keeps changing hands; try again")


def _cancel(task_id: int, by, now: datetime, history_count: int | None) -> Task:
    task = _with_robot_locked(task_id)
    if history_count is not None and task.history.count() != history_count:
        raise TaskChanged(f"{task.code} has changed")
    if task.status in FINISHED_STATUSES or task.status == TaskStatus.DELIVERED:
        raise TaskNotCancellable(f"{task.code} is {task.get_status_display().lower()}")
    if task.return_trip:
        raise TaskNotCancellable(f"{task.code} is already returning to its pick-up point")
    before = task.status
    done = _cancel_as_it_stands(task, by, now)
    entry_record(
        kind=Kind.TASK_CANCELLED,
        obj=done,
        actor=by,
        changes={"status": [before, done.status]},
        data={"return_trip": bool(done.return_trip)},
    )
    return done


def _cancel_as_it_stands(task: Task, by, now: datetime) -> Task:
    if task.robot is None:
        return _cancel_waiting(task, by, now)
    stops = list(task.stops.select_related("waypoint"))
    if any(stop.done_at for stop in stops):
        return _return_trip(task, stops, by, now)
    return _cancel_held(task, by, now)


def _with_robot_locked(task_id: int) -> Task:
    """The task, with its robot's row locked if it has one."""
    task = Task.objects.get(pk=task_id)
    if task.robot_id is None:
        return task
    robot = robot_lock(task.robot_id)
    task = Task.objects.get(pk=task_id)
    if task.robot_id != robot.pk:
        raise _Moved
    task.robot = robot
    return task


def _cancel_waiting(task: Task, by, now: datetime) -> Task:
    # The status as read: a task made due or allocated meanwhile is read again (and its
    # history counted again).
    claimed = Task.objects.filter(
        pk=task.pk, status=task.status, status__in=WAITING_STATUSES, robot__isnull=True
    ).update(status=TaskStatus.CANCELLED, cancelled_at=now)
    if not claimed:
        raise _Moved  # allocated or made due meanwhile
    old, task.status, task.cancelled_at = task.status, TaskStatus.CANCELLED, now
    task_record(task, old=old, at=now, cause=Cause.USER, user=by, note="cancelled")
    return task


def _cancel_held(task: Task, by, now: datetime) -> Task:
    robot = task.robot
    if task.status == TaskStatus.ASSIGNED:
        plan_withdraw_pending(robot=robot, reason=f"{task.code} cancelled", now=now)
    task.cancelled_at, task.eta = now, None
    note = Said(gettext_noop("cancelled; %(robot)s gets a plan without it"), robot=robot.code)
    why = {"cause": Cause.USER, "user": by, "robot": robot, "note": note}
    task_move(task, TaskStatus.CANCELLED, at=now, fields=["cancelled_at", "eta"], **why)
    robot_replan(robot=robot, now=now)
    return task


def _return_trip(task: Task, stops: list[TaskStop], by, now: datetime) -> Task:
    """Drop what is left of the task; add a drop-off of what is on board where it came from."""
    origin = task_origin(stops)
    on_board = return_stop_add(task=task, stops=stops, waypoint=origin.waypoint, now=now)
    task.return_trip = True
    task.picked_up_at = task.picked_up_at or now
    note = Said(
        gettext_noop("cancelled after pick-up: returning %(count)s item(s) to %(place)s"),
        count=on_board,
        place=origin.waypoint.code,
    )
    why = {"cause": Cause.USER, "user": by, "robot": task.robot, "note": note}
    fields = ["return_trip", "picked_up_at"]
    task_move(task, TaskStatus.PICKED_UP, at=now, fields=fields, **why)
    robot_replan(robot=task.robot, now=now)
    return task


def task_origin(stops: list[TaskStop]) -> TaskStop:
    """The task's first pick-up: where a return trip takes its items back to."""
    return min((s for s in stops if s.action == StopAction.PICKUP), key=lambda s: s.index)


def return_stop_add(*, task: Task, stops: list[TaskStop], waypoint, now: datetime) -> int:
    """Skip the task's remaining stops and add one drop-off at `waypoint` of what is on board,
    numbered after its last stop; returns how many items that is. Call with the robot locked."""
    remaining = [stop for stop in stops if stop.is_remaining]
    for stop in remaining:
        stop.skipped_at = now
    TaskStop.objects.bulk_update(remaining, ["skipped_at"])
    on_board = sum(stop.load_change for stop in stops if stop.done_at)
    TaskStop.objects.create(
        task=task,
        index=max(stop.index for stop in stops) + 1,
        action=StopAction.DROPOFF,
        waypoint=waypoint,
        load_change=-on_board,
    )
    return on_board
