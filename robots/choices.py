from django.db import models
from django.utils.translation import gettext_lazy as _


class WaypointKind(models.TextChoices):
    PLAIN = "plain", _("Plain")
    STATION = "station", _("Station")
    DOCK = "dock", _("Dock")
    RESOURCE_WAIT = "resource_wait", _("Resource waiting area")
    # Off the escape routes: where robots wait out a fire alarm (scheduling.services.emergency).
    REFUGE = "refuge", _("Refuge point")


class ResourceKind(models.TextChoices):
    ELEVATOR = "elevator", _("Elevator")
    DOOR = "door", _("Automatic door")
    CORRIDOR = "corridor", _("Narrow corridor")


class RobotStatus(models.TextChoices):
    """What the robot says it is doing (protocol v1, state.status)."""

    UNKNOWN = "unknown", _("Not reported yet")
    IDLE = "idle", _("Idle")
    MOVING = "moving", _("Moving")
    WAITING_LOAD = "waiting_load", _("Waiting for loading")
    WAITING_UNLOAD = "waiting_unload", _("Waiting for unloading")
    WAITING_RESOURCE = "waiting_resource", _("Waiting for a resource")
    IN_RESOURCE = "in_resource", _("In a resource")
    CHARGING = "charging", _("Charging")
    PAUSED = "paused", _("Paused")
    ERROR = "error", _("Error")


REPORTABLE_STATUSES = [value for value in RobotStatus.values if value != RobotStatus.UNKNOWN]


class Presence(models.TextChoices):
    """What the server concludes from when heartbeats arrive (protocol v1, "Presence")."""

    ONLINE = "online", _("Online")
    UNREACHABLE = "unreachable", _("Unreachable")
    OFFLINE = "offline", _("Offline")


class RobotProtocol(models.TextChoices):
    """How a robot talks to the server: our heartbeats, or VDA 5050 over MQTT (the vda5050
    bridge translates)."""

    HEARTBEAT = "heartbeat", _("Heartbeat (protocol v1)")
    VDA5050 = "vda5050", _("VDA 5050 over MQTT")


class VdaQuirk(models.TextChoices):
    """Deviations from VDA 5050 2.0 found in vehicles in the field, switched on per vehicle in
    the site file (its `vda5050.quirks`); the integrators' VDA 5050 page names who needs each."""

    INSTANT_ACTIONS_FIELD = "instant_actions_field", _("instantActions holds its list (1.1 name)")
    INIT_POSITION_AFTER_LIFT = (
        "init_position_after_lift",
        "initPosition at the lift's exit node (it keeps its map otherwise)",
    )


class EmergencyKind(models.TextChoices):
    """A state of the building in which robots stop their ordinary work."""

    FIRE_ALARM = "fire_alarm", _("Fire alarm")


class EmergencySource(models.TextChoices):
    """Who started or ended an emergency mode."""

    OPERATOR = "operator", _("An operator, on the fleet page")
    API = "api", _("A building management system, over the REST API")
    BUILDING = "building", _("The building's fire panel, over MQTT")
