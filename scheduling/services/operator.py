"""Operators' commands to a robot: Pause, Resume, Return to dock (protocol v1 `action`).

* Pause: the robot is told to pause and gets no new tasks until an operator resumes it; it
  keeps the tasks it holds.
* Resume: the robot is told to resume and is offered tasks again; a fault it reported
  (scheduling.services.faults) is resolved and its alert closed.
* Return to dock: the robot gets no new tasks until resumed, and the tasks it has not picked
  up go back to the scheduler (scheduling.services.presence.robot_tasks_give_back), which
  posts it a corrected plan: the drop-offs of what is on board, or its dock. Then it is told
  to return to its dock. Items on board stay with it. A fault is resolved, as by Resume.

The action travels on the robot's board like any message, so a robot out of reach gets it on
its next heartbeat. A newer action withdraws one the robot has not acked yet: a robot out of
reach gets only the operator's latest command.
"""

from datetime import datetime

from django.db import transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from audit.choices import Kind
from audit.services import entry_record
from boards import protocol
from boards.choices import MessageType
from boards.services import board_post
from core.said import Said
from resources.availability import (
    resource_priority_end,
    resource_priority_start,
    resource_return_to_service,
    resource_take_out_of_service,
)
from robots.models import Resource, Robot
from robots.services import robot_lock, robot_publish
from scheduling.choices import ROUTE_STATUSES, Cause, OperatorActionKind, ResourceActionKind
from scheduling.models import OperatorAction, Task
from scheduling.services.faults import robot_fault_resolve
from scheduling.services.history import task_record
from scheduling.services.presence import robot_tasks_give_back

ACTION_KEY = "action"


@transaction.atomic
def robot_action(*, robot: Robot, action: str, by, now: datetime | None = None) -> OperatorAction:
    """Post `action` for the robot, with its row locked, and record who asked for it."""
    if action not in OperatorActionKind.values:
        raise ValueError(f"unknown action {action!r}")
    now = now or timezone.now()
    robot = robot_lock(robot.pk)
    if action == OperatorActionKind.RETURN_TO_DOCK:
        # First, so the corrected plan reaches the robot before the action does.
        robot_tasks_give_back(robot=robot, at=now, by=by)
    message = board_post(
        robot=robot,
        type=MessageType.ACTION,
        body=protocol.action_body(action=action),
        key=ACTION_KEY,
        supersede=True,
        robot_locked=True,
    )
    # Resume or Return to dock resolves a fault: the operator has seen to the robot.
    if action != OperatorActionKind.PAUSE:
        robot_fault_resolve(robot=robot, by=by, at=now)
    held = action != OperatorActionKind.RESUME
    if robot.paused_by_operator != held:
        robot.paused_by_operator = held
        robot.save(update_fields=["paused_by_operator"])
        robot_publish(robot=robot)
    _tell_held_tasks(robot, action, by, now)
    return operator_action_record(robot=robot, action=action, by=by, at=now, message=message)


# What the tasks still on the robot's route record, in their requesters' words.
_HELD_NOTES = {
    OperatorActionKind.PAUSE: gettext_noop("Held by an operator"),
    OperatorActionKind.RESUME: gettext_noop("Released by an operator: on its way again"),
    OperatorActionKind.RETURN_TO_DOCK: gettext_noop(
        "%(robot)s recalled by an operator, with the items on board"
    ),
}


def _tell_held_tasks(robot: Robot, action: str, by, now: datetime) -> None:
    """Record the action in the history of each task still on the robot's route, which also
    updates their rows on the requesters' pages."""
    note = Said(_HELD_NOTES[action], robot=robot.code)
    for task in Task.objects.filter(robot=robot, status__in=ROUTE_STATUSES):
        task_record(
            task, old=task.status, at=now, cause=Cause.USER, robot=robot, user=by, note=note
        )


@transaction.atomic
def resource_operator_set_service(
    *, resource: Resource, in_service: bool, by, reason: str = "", now: datetime | None = None
) -> OperatorAction | None:
    """An operator takes a resource out of service (with a reason) or returns it; recorded.
    None if it already was so (nothing changed, nothing recorded)."""
    now = now or timezone.now()
    if in_service:
        changed = resource_return_to_service(resource=resource, actor=by, now=now)
        action = ResourceActionKind.BACK_IN_SERVICE
    else:
        changed = resource_take_out_of_service(resource=resource, reason=reason, actor=by, now=now)
        action = ResourceActionKind.OUT_OF_SERVICE
    if not changed:
        return None
    return operator_action_record(
        resource=resource, action=action, by=by, at=now, note=reason[:200]
    )


@transaction.atomic
def resource_operator_set_priority(
    *, resource: Resource, on: bool, by, reason: str = "", now: datetime | None = None
) -> OperatorAction | None:
    """An operator (or a building management system) holds an elevator for an emergency team
    (with a reason) or releases it; recorded. None if it already was so."""
    now = now or timezone.now()
    if on:
        changed = resource_priority_start(resource=resource, reason=reason, actor=by, now=now)
        action = ResourceActionKind.LIFT_PRIORITY
    else:
        changed = resource_priority_end(resource=resource, actor=by, now=now)
        action = ResourceActionKind.PRIORITY_END
    if not changed:
        return None
    return operator_action_record(
        resource=resource, action=action, by=by, at=now, note=reason[:200]
    )


def resource_operator_record(
    *, resource: Resource, action: str, by, note: str = "", now: datetime | None = None
) -> OperatorAction:
    """A command of an operator to a lift or door (Hold doors, Let doors go, Send car),
    recorded with who, when and what like the other operator actions; the caller sends the
    command in the same transaction."""
    return operator_action_record(
        resource=resource, action=action, by=by, at=now or timezone.now(), note=note[:200]
    )


def operator_action_record(*, by, **fields) -> OperatorAction:
    """Store the operator's action and its audit entry, on the robot or resource it acted on.
    Every operator action is stored through here, so none escapes the audit trail."""
    done = OperatorAction.objects.create(by=by, **fields)
    target = done.robot or done.resource
    entry_record(
        kind=Kind.OPERATOR_ACTION,
        obj=target,
        actor=by,
        object_repr=f"{done.get_action_display()}: {target}",
        data={"action": done.action, "note": done.note},
    )
    return done
