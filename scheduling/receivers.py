"""The scheduler's reactions to robots: connected in SchedulingConfig.ready()."""

from boards.signals import heartbeat_applied
from robots.choices import Presence
from robots.signals import presence_changed
from scheduling import services


def on_heartbeat_applied(sender, applied, **kwargs):
    services.heartbeat_tasks_apply(applied=applied)


def on_presence_changed(sender, robot, old, new, at, **kwargs):
    if new == Presence.OFFLINE:
        services.robot_offline(robot=robot, at=at)


def connect() -> None:
    heartbeat_applied.connect(on_heartbeat_applied, dispatch_uid="scheduling-heartbeat")
    presence_changed.connect(on_presence_changed, dispatch_uid="scheduling-presence")
