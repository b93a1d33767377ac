from django.db import models


class MessageType(models.TextChoices):
    """Board messages the server posts for a robot (protocol v1, response body)."""

    PLAN = "plan", "Plan"
    RESOURCE_GRANT = "resource_grant", "Resource grant"
    RESOURCE_QUEUED = "resource_queued", "Resource queued"
    ACTION = "action", "Action"
    # Additions (docs/robot-protocol.md): the server's building devices and resources' service.
    RESOURCE_OUT_OF_SERVICE = "resource_out_of_service", "Resource out of service"
    RESOURCE_IN_SERVICE = "resource_in_service", "Resource back in service"
    ELEVATOR_AT_FLOOR = "elevator_at_floor", "Elevator stopped at a floor"


class EventType(models.TextChoices):
    """Events robots report (protocol v1, events[].type)."""

    TASK_RECEIVED = "task_received", "Task received"
    ARRIVED = "arrived", "Arrived"
    LOADED = "loaded", "Loaded"
    UNLOADED = "unloaded", "Unloaded"
    TASK_COMPLETED = "task_completed", "Task completed"
    TASK_FAILED = "task_failed", "Task failed"
    RESOURCE_ENTERED = "resource_entered", "Resource entered"
    RESOURCE_RELEASED = "resource_released", "Resource released"
    COMPARTMENT_LOCKED = "compartment_locked", "Compartment kept locked after wrong PINs"


class OpenedWith(models.TextChoices):
    """How a compartment was opened (events[].opened_with, secure deliveries)."""

    PIN = "pin", "the delivery's PIN"
    BADGE = "badge", "a badge"
    STAFF = "staff", "staff at the robot"


RESOURCE_EVENT_TYPES = {EventType.RESOURCE_ENTERED, EventType.RESOURCE_RELEASED}


class RequestType(models.TextChoices):
    """Requests robots make in heartbeats (protocol v1, requests[].type)."""

    ACQUIRE = "acquire", "Acquire"
    RELEASE = "release", "Release"
