"""Signal receivers of the robots app: the resource controller's hooks into heartbeats and
presence. Connected in RobotsConfig.ready()."""

from django.dispatch import receiver

from boards.signals import heartbeat_applied
from robots.choices import Presence
from robots.leases import lease_drop_waiting, lease_heartbeat_apply
from robots.signals import presence_changed


@receiver(heartbeat_applied, dispatch_uid="robots.leases.heartbeat")
def leases_on_heartbeat(sender, applied, **kwargs):
    lease_heartbeat_apply(applied=applied)


@receiver(presence_changed, dispatch_uid="robots.leases.presence")
def leases_on_presence(sender, robot, new, at, **kwargs):
    if new == Presence.OFFLINE:
        lease_drop_waiting(robot=robot, now=at)
