from django.db import models


class WaypointKind(models.TextChoices):
    PLAIN = "plain", "Plain"
    STATION = "station", "Station"
    DOCK = "dock", "Dock"
    RESOURCE_WAIT = "resource_wait", "Resource waiting area"


class ResourceKind(models.TextChoices):
    ELEVATOR = "elevator", "Elevator"
    DOOR = "door", "Automatic door"
    CORRIDOR = "corridor", "Narrow corridor"


class RobotStatus(models.TextChoices):
    """What the robot says it is doing (protocol v1, state.status)."""

    UNKNOWN = "unknown", "Not reported yet"
    IDLE = "idle", "Idle"
    MOVING = "moving", "Moving"
    WAITING_LOAD = "waiting_load", "Waiting for loading"
    WAITING_UNLOAD = "waiting_unload", "Waiting for unloading"
    WAITING_RESOURCE = "waiting_resource", "Waiting for a resource"
    IN_RESOURCE = "in_resource", "In a resource"
    CHARGING = "charging", "Charging"
    PAUSED = "paused", "Paused"
    ERROR = "error", "Error"


REPORTABLE_STATUSES = [value for value in RobotStatus.values if value != RobotStatus.UNKNOWN]


class Presence(models.TextChoices):
    """What the server concludes from when heartbeats arrive (protocol v1, "Presence")."""

    ONLINE = "online", "Online"
    UNREACHABLE = "unreachable", "Unreachable"
    OFFLINE = "offline", "Offline"


class LeaseState(models.TextChoices):
    """A robot's hold on a resource (protocol v1, "Resources"); see robots/leases.py."""

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


class OperatorActionKind(models.TextChoices):
    """What an operator can tell a robot (protocol v1 `action` message)."""

    PAUSE = "pause", "Pause"
    RESUME = "resume", "Resume"
    RETURN_TO_DOCK = "return_to_dock", "Return to dock"
