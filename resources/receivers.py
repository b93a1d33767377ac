"""The resource controller's receivers of lower layers' hooks (connected, in order, in
hospital_delivery/extensions.py)."""

from resources.leases import lease_drop_waiting, lease_heartbeat_apply
from robots.choices import Presence


def on_heartbeat_applied(*, applied) -> None:
    lease_heartbeat_apply(applied=applied)


def on_presence_changed(*, robot, old, new, at) -> None:
    if new == Presence.OFFLINE:
        lease_drop_waiting(robot=robot, now=at)
