from django.db import models


class AdapterKind(models.TextChoices):
    """How the server drives a device (building/adapters/)."""

    SIM = "sim", "Simulated"
    MQTT = "mqtt", "MQTT (a building integrator's controller)"


class DoorState(models.TextChoices):
    """A lift's doors or a door (Open-RMF's DOOR_CLOSED=0, DOOR_MOVING=1, DOOR_OPEN=2)."""

    CLOSED = "closed", "Closed"
    MOVING = "moving", "Opening or closing"
    OPEN = "open", "Open"


class Motion(models.TextChoices):
    """A lift car's motion (Open-RMF's MOTION_STOPPED=0, UP=1, DOWN=2, UNKNOWN=3)."""

    STOPPED = "stopped", "Stopped"
    UP = "up", "Going up"
    DOWN = "down", "Going down"
    UNKNOWN = "unknown", "Unknown"
