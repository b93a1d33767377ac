from django.db import models


class LeaseState(models.TextChoices):
    """A robot's hold on a resource (protocol v1, "Resources"); see resources/leases.py."""

    QUEUED = "queued", "Queued"
    GRANTED = "granted", "Granted, not entered yet"
    ENTERED = "entered", "Inside the resource"
    RELEASED = "released", "Released by the robot"
    EXPIRED = "expired", "Grant expired (not entered in time)"
    REVOKED = "revoked", "Force-released by an administrator"
    DROPPED = "dropped", "Dropped (robot went offline while waiting)"


LIVE_LEASE_STATES = [LeaseState.QUEUED, LeaseState.GRANTED, LeaseState.ENTERED]
HOLDING_LEASE_STATES = [LeaseState.GRANTED, LeaseState.ENTERED]


class LeaseEndCause(models.TextChoices):
    RELEASE_REQUEST = "release_request", "Robot's release request"
    RELEASED_EVENT = "released_event", "Robot reported resource_released"
    GRANT_TIMEOUT = "grant_timeout", "Grant not taken up before it expired"
    ROBOT_OFFLINE = "robot_offline", "Robot went offline while waiting"
    ADMIN = "admin", "Administrator"
    DEADLOCK = "deadlock", "Yielded to break a deadlock (queued again)"
