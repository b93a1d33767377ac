"""Robots out of service for maintenance: taken out by an operator with a reason (and
optionally until a time), returned by an operator or when that time comes.

Taken out, a robot is planned nothing new (robots.selectors.available_robots); the tasks it
has not picked up go back to the scheduler at once, for other robots; what it carries is
handed back at each task's pick-up point (a return trip, as a cancellation after pick-up:
the delivery ends cancelled there, and its requester sees why), then it goes to its dock.
The robot needs no new message: it gets the corrected plan, in protocol v1.

Each change is an OperatorAction row: who, when, why (the sweep's return has no one).
"""

from datetime import datetime

from django.db import transaction
from django.utils import timezone

from robots.models import Robot
from robots.services import robot_lock, robot_publish
from scheduling.choices import ROUTE_STATUSES, Cause, MaintenanceActionKind, TaskStatus
from scheduling.models import OperatorAction, Task
from scheduling.services.cancellation import return_stop_add, task_origin
from scheduling.services.history import task_move
from scheduling.services.operator import operator_action_record
from scheduling.services.plans import robot_replan
from scheduling.services.presence import robot_tasks_give_back

REASON_MAX = 200
FIELDS = ["maintenance_since", "maintenance_until", "maintenance_reason"]


class MaintenanceRefused(Exception):
    """The request cannot be carried out; `field` names what is wrong (None: the state)."""

    def __init__(self, message: str, *, field: str | None = None):
        super().__init__(message)
        self.field = field


@transaction.atomic
def robot_maintenance_start(
    *,
    robot: Robot,
    reason: str,
    until: datetime | None = None,
    by=None,
    now: datetime | None = None,
) -> OperatorAction:
    """Take the robot out of service; MaintenanceRefused if it already is, or `until` has
    passed."""
    now = now or timezone.now()
    if until is not None and until <= now:
        raise MaintenanceRefused("The time to return it must be in the future.", field="until")
    robot = robot_lock(robot.pk)
    if robot.maintenance_since is not None:
        raise MaintenanceRefused(f"{robot.code} is already in maintenance.")
    robot.maintenance_since, robot.maintenance_until = now, until
    robot.maintenance_reason = reason[:REASON_MAX]
    robot.save(update_fields=FIELDS)
    note = f"{robot.code} taken into maintenance by an operator: given to another robot"
    robot_tasks_give_back(robot=robot, at=now, by=by, note=note)
    if _hand_back_loaded(robot, by, now):
        robot_replan(robot=robot, now=now)
    robot_publish(robot=robot)
    return operator_action_record(
        robot=robot, action=MaintenanceActionKind.MAINTENANCE, by=by, at=now, note=reason[:200]
    )


@transaction.atomic
def robot_maintenance_end(
    *, robot: Robot, by=None, note: str = "", now: datetime | None = None
) -> OperatorAction:
    """Return the robot to service; MaintenanceRefused if it was not in maintenance."""
    now = now or timezone.now()
    robot = robot_lock(robot.pk)
    if robot.maintenance_since is None:
        raise MaintenanceRefused(f"{robot.code} is not in maintenance.")
    return _returned(robot, by, note, now)


def maintenance_due_sweep(*, now: datetime | None = None) -> int:
    """Return to service the robots whose maintenance time has come; returns how many.

    Each is claimed by a conditional UPDATE: 0 rows means an operator returned it first."""
    now = now or timezone.now()
    due = Robot.objects.filter(maintenance_until__lte=now).values_list("pk", flat=True)
    return sum(_return_when_due(pk, now) for pk in due)


@transaction.atomic
def _return_when_due(robot_id: int, now: datetime) -> bool:
    claimed = Robot.objects.filter(pk=robot_id, maintenance_until__lte=now)
    if not claimed.update(maintenance_since=None, maintenance_until=None, maintenance_reason=""):
        return False
    robot = robot_lock(robot_id)
    robot_publish(robot=robot)
    operator_action_record(
        robot=robot,
        action=MaintenanceActionKind.RETURNED,
        by=None,
        at=now,
        note="its maintenance ended",
    )
    return True


def _returned(robot: Robot, by, note: str, now: datetime) -> OperatorAction:
    robot.maintenance_since = robot.maintenance_until = None
    robot.maintenance_reason = ""
    robot.save(update_fields=FIELDS)
    robot_publish(robot=robot)
    return operator_action_record(
        robot=robot, action=MaintenanceActionKind.RETURNED, by=by, at=now, note=note[:200]
    )


def _hand_back_loaded(robot: Robot, by, now: datetime) -> int:
    """A return trip to its pick-up point for each task with items on board; how many."""
    tasks = Task.objects.filter(robot=robot, status__in=ROUTE_STATUSES, return_trip=False)
    handed = 0
    for task in tasks.prefetch_related("stops__waypoint"):
        stops = list(task.stops.all())
        if not any(stop.done_at for stop in stops):
            continue
        origin = task_origin(stops)
        on_board = return_stop_add(task=task, stops=stops, waypoint=origin.waypoint, now=now)
        task.return_trip = True
        note = (
            f"{robot.code} taken into maintenance: handing {on_board} item(s) back at "
            f"{origin.waypoint.code}; the delivery ends there, order it again"
        )
        why = {"cause": Cause.USER, "user": by, "robot": robot, "note": note}
        task_move(task, TaskStatus.PICKED_UP, at=now, fields=["return_trip"], **why)
        handed += 1
    return handed
