"""The scheduler's reactions to robots: connected in SchedulingConfig.ready()."""

from boards.signals import heartbeat_applied
from robots.choices import OperatorActionKind, Presence
from robots.signals import operator_action, presence_changed
from scheduling import services


def on_heartbeat_applied(sender, applied, **kwargs):
    services.heartbeat_tasks_apply(applied=applied)


def on_presence_changed(sender, robot, old, new, at, **kwargs):
    if new == Presence.OFFLINE:
        services.robot_offline(robot=robot, at=at)


def on_operator_action(sender, robot, action, by, at, **kwargs):
    if action == OperatorActionKind.RETURN_TO_DOCK:
        services.robot_tasks_give_back(robot=robot, at=at, by=by)


def connect() -> None:
    heartbeat_applied.connect(on_heartbeat_applied, dispatch_uid="scheduling-heartbeat")
    presence_changed.connect(on_presence_changed, dispatch_uid="scheduling-presence")
    operator_action.connect(on_operator_action, dispatch_uid="scheduling-operator-action")
