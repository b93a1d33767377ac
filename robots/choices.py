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


class RobotProtocol(models.TextChoices):
    """How a robot talks to the server: our heartbeats, or VDA 5050 over MQTT (the vda5050
    bridge translates)."""

    HEARTBEAT = "heartbeat", "Heartbeat (protocol v1)"
    VDA5050 = "vda5050", "VDA 5050 over MQTT"


class EmergencyKind(models.TextChoices):
    """A state of the building in which robots stop their ordinary work."""

    FIRE_ALARM = "fire_alarm", "Fire alarm"


class EmergencySource(models.TextChoices):
    """Who started or ended an emergency mode."""

    OPERATOR = "operator", "An operator, on the fleet page"
    API = "api", "A building management system, over the REST API"
