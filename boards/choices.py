from django.db import models
from django.utils.translation import gettext_lazy as _


class MessageType(models.TextChoices):
    """Board messages the server posts for a robot (protocol v1, response body)."""

    PLAN = "plan", _("Plan")
    RESOURCE_GRANT = "resource_grant", _("Resource grant")
    RESOURCE_QUEUED = "resource_queued", _("Resource queued")
    ACTION = "action", _("Action")
    # Additions (docs/robot-protocol.md): the server's building devices and resources' service.
    RESOURCE_OUT_OF_SERVICE = "resource_out_of_service", _("Resource out of service")
    RESOURCE_IN_SERVICE = "resource_in_service", _("Resource back in service")
    ELEVATOR_AT_FLOOR = "elevator_at_floor", _("Elevator stopped at a floor")
    ELEVATOR_EXIT = "elevator_exit", _("Get out of the elevator at the next floor")


class EventType(models.TextChoices):
    """Events robots report (protocol v1, events[].type)."""

    TASK_RECEIVED = "task_received", _("Task received")
    ARRIVED = "arrived", _("Arrived")
    LOADED = "loaded", _("Loaded")
    UNLOADED = "unloaded", _("Unloaded")
    TASK_COMPLETED = "task_completed", _("Task completed")
    TASK_FAILED = "task_failed", _("Task failed")
    RESOURCE_ENTERED = "resource_entered", _("Resource entered")
    RESOURCE_RELEASED = "resource_released", _("Resource released")
    COMPARTMENT_LOCKED = "compartment_locked", _("Compartment kept locked after wrong PINs")


class OpenedWith(models.TextChoices):
    """How a compartment was opened (events[].opened_with, secure deliveries)."""

    PIN = "pin", _("the delivery's PIN")
    BADGE = "badge", _("a badge")
    STAFF = "staff", _("staff at the robot")


RESOURCE_EVENT_TYPES = {EventType.RESOURCE_ENTERED, EventType.RESOURCE_RELEASED}


class RequestType(models.TextChoices):
    """Requests robots make in heartbeats (protocol v1, requests[].type)."""

    ACQUIRE = "acquire", _("Acquire")
    RELEASE = "release", _("Release")
