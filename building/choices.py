from django.db import models
from django.utils.translation import gettext_lazy as _


class AdapterKind(models.TextChoices):
    """How the server drives a device (building/adapters/)."""

    SIM = "sim", _("Simulated")
    MQTT = "mqtt", _("MQTT (a building integrator's controller)")


class DoorState(models.TextChoices):
    """A lift's doors or a door (Open-RMF's DOOR_CLOSED=0, DOOR_MOVING=1, DOOR_OPEN=2)."""

    CLOSED = "closed", _("Closed")
    MOVING = "moving", _("Opening or closing")
    OPEN = "open", _("Open")


class Motion(models.TextChoices):
    """A lift car's motion (Open-RMF's MOTION_STOPPED=0, UP=1, DOWN=2, UNKNOWN=3)."""

    STOPPED = "stopped", _("Stopped")
    UP = "up", _("Going up")
    DOWN = "down", _("Going down")
    UNKNOWN = "unknown", _("Unknown")
