"""Operators' commands to a robot: Pause, Resume, Return to dock (protocol v1 `action`).

* Pause: the robot is told to pause and gets no new tasks until an operator resumes it; it
  keeps the tasks it holds.
* Resume: the robot is told to resume and is offered tasks again.
* Return to dock: the robot gets no new tasks until resumed, and the tasks it has not picked
  up go back to the scheduler (scheduling.services.presence.robot_tasks_give_back), which
  posts it a corrected plan: the drop-offs of what is on board, or its dock. Then it is told
  to return to its dock. Items on board stay with it.

The action travels on the robot's board like any message, so a robot out of reach gets it on
its next heartbeat. A newer action withdraws one the robot has not acked yet: a robot out of
reach gets only the operator's latest command.
"""

from datetime import datetime

from django.db import transaction
from django.utils import timezone

from boards import protocol
from boards.choices import MessageType
from boards.services import board_post
from robots.models import Robot
from robots.services import robot_lock, robot_publish
from scheduling.choices import OperatorActionKind
from scheduling.models import OperatorAction
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
    held = action != OperatorActionKind.RESUME
    if robot.paused_by_operator != held:
        robot.paused_by_operator = held
        robot.save(update_fields=["paused_by_operator"])
        robot_publish(robot=robot)
    return OperatorAction.objects.create(robot=robot, action=action, by=by, at=now, message=message)
