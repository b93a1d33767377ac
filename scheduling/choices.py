from django.db import models
from django.utils.translation import gettext_lazy as _


class TaskStatus(models.TextChoices):
    """Where a delivery task is in its lifecycle (see scheduling/services/__init__.py)."""

    SCHEDULED = "scheduled", _("Scheduled")
    DUE = "due", _("Due, waiting for a robot")
    ASSIGNED = "assigned", _("Robot chosen")
    ACKNOWLEDGED = "acknowledged", _("Robot on its way")
    PICKED_UP = "picked_up", _("Picked up")
    DELIVERED = "delivered", _("Delivered")
    COMPLETED = "completed", _("Completed")
    CANCELLED = "cancelled", _("Cancelled")
    FAILED = "failed", _("Failed")


# Held by a robot: the task has a robot and (until delivered) stops on its route.
HELD_STATUSES = [
    TaskStatus.ASSIGNED,
    TaskStatus.ACKNOWLEDGED,
    TaskStatus.PICKED_UP,
    TaskStatus.DELIVERED,
]
# On a robot's route: stops left to visit.
ROUTE_STATUSES = [TaskStatus.ASSIGNED, TaskStatus.ACKNOWLEDGED, TaskStatus.PICKED_UP]
WAITING_STATUSES = [TaskStatus.SCHEDULED, TaskStatus.DUE]
# The lifecycle is over: robot events about the task are only recorded in its history.
FINISHED_STATUSES = [TaskStatus.COMPLETED, TaskStatus.CANCELLED, TaskStatus.FAILED]


class Priority(models.TextChoices):
    """How soon a delivery is needed; each has a due-by time (the site's default, or the
    request's own) and a weight in the allocator's objective."""

    ROUTINE = "routine", _("Routine")
    URGENT = "urgent", _("Urgent")
    STAT = "stat", _("STAT")


# Old names still accepted on the API: "normal" was routine's name before deadlines.
PRIORITY_ALIASES = {"normal": Priority.ROUTINE}
# Due sweeps allocate in this order (lowest first).
PRIORITY_RANK = {Priority.STAT: 0, Priority.URGENT: 1, Priority.ROUTINE: 2}
# Lateness and delivery time of a task count this many times in the allocator's objective.
PRIORITY_WEIGHT = {Priority.STAT: 8.0, Priority.URGENT: 3.0, Priority.ROUTINE: 1.0}
# What protocol v1 robots are told (v1 knows "normal" and "urgent" only).
PRIORITY_ON_THE_WIRE = {
    Priority.ROUTINE: "normal",
    Priority.URGENT: "urgent",
    Priority.STAT: "urgent",
}


class StopAction(models.TextChoices):
    PICKUP = "pickup", _("Pick-up")
    DROPOFF = "dropoff", _("Drop-off")


class Cause(models.TextChoices):
    """Why a task changed (TaskTransition.cause)."""

    REQUEST = "request", _("Requested")
    SCHEDULE = "schedule", _("Periodic request")
    SWEEP = "sweep", _("Requested time reached")
    UNLOADING = "unloading", _("Nobody unloaded it in time")
    ALLOCATION = "allocation", _("Allocated")
    ROBOT_ACK = "robot_ack", _("Robot acknowledged its plan")
    ROBOT_EVENT = "robot_event", _("Reported by the robot")
    ACK_TIMEOUT = "ack_timeout", _("Not acknowledged in time")
    PRESENCE = "presence", _("Robot went offline")
    USER = "user", _("User")
    ROBOT_FAULT = "robot_fault", _("Robot fault")
    ANOMALY = "anomaly", _("Event out of order (ignored)")


class OperatorActionKind(models.TextChoices):
    """What an operator can tell a robot (protocol v1 `action` message)."""

    PAUSE = "pause", _("Pause")
    RESUME = "resume", _("Resume")
    RETURN_TO_DOCK = "return_to_dock", _("Return to dock")


class ResourceActionKind(models.TextChoices):
    """What an operator can do to an elevator, door or corridor (resources/availability.py),
    and to the lift or door the server drives (building/services.py)."""

    OUT_OF_SERVICE = "out_of_service", _("Take out of service")
    BACK_IN_SERVICE = "back_in_service", _("Return to service")
    HOLD_DOORS = "hold_doors", _("Hold doors")
    RELEASE_DOORS = "release_doors", _("Let doors go")
    SEND_CAR = "send_car", _("Send car")
    LIFT_PRIORITY = "lift_priority", _("Lift priority")
    PRIORITY_END = "priority_end", _("Lift priority released")


class MaintenanceActionKind(models.TextChoices):
    """An operator takes a robot out of service for maintenance, or returns it (or its time
    ends): scheduling/services/maintenance.py."""

    MAINTENANCE = "maintenance", _("Taken into maintenance")
    RETURNED = "maintenance_end", _("Returned from maintenance")


OPERATOR_ACTION_CHOICES = [
    *OperatorActionKind.choices,
    *ResourceActionKind.choices,
    *MaintenanceActionKind.choices,
]
