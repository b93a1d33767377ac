from django.db import models
from django.utils.translation import gettext_lazy as _


class LeaseState(models.TextChoices):
    """A robot's hold on a resource (protocol v1, "Resources"); see resources/leases.py."""

    QUEUED = "queued", _("Queued")
    GRANTED = "granted", _("Granted, not entered yet")
    ENTERED = "entered", _("Inside the resource")
    RELEASED = "released", _("Released by the robot")
    EXPIRED = "expired", _("Grant expired (not entered in time)")
    REVOKED = "revoked", _("Force-released by an administrator")
    DROPPED = "dropped", _("Dropped (robot went offline while waiting)")


LIVE_LEASE_STATES = [LeaseState.QUEUED, LeaseState.GRANTED, LeaseState.ENTERED]
HOLDING_LEASE_STATES = [LeaseState.GRANTED, LeaseState.ENTERED]


class LeaseEndCause(models.TextChoices):
    RELEASE_REQUEST = "release_request", _("Robot's release request")
    RELEASED_EVENT = "released_event", _("Robot reported resource_released")
    GRANT_TIMEOUT = "grant_timeout", _("Grant not taken up before it expired")
    ROBOT_OFFLINE = "robot_offline", _("Robot went offline while waiting")
    ADMIN = "admin", _("Administrator")
    DEADLOCK = "deadlock", _("Yielded to break a deadlock (queued again)")
