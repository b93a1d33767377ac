from django.conf import settings
from django.db import models
from django.db.models import Q
from django.utils import timezone
from django.utils.translation import gettext_lazy as _

from core.said import said_text
from robots.models.fleet import Robot
from robots.models.map import Resource, Site


class AlertKind(models.TextChoices):
    LEASE_HARD_LIMIT = "lease_hard_limit", _("Robot silent inside a resource past the hard limit")
    ENTERED_WITHOUT_GRANT = "entered_without_grant", _("Robot entered a resource without a grant")
    TASK_FAILED = "task_failed", _("Delivery failed")
    OFFLINE_WITH_LOAD = "offline_with_load", _("Robot offline with items on board")
    ROBOT_ERROR = "robot_error", _("Robot reports an error")
    EVENT_ANOMALY = "event_anomaly", _("Robot event that does not fit the delivery")
    COMPARTMENT_LOCKED = "compartment_locked", _("Compartment kept locked after wrong PINs")
    UNLOAD_TIMEOUT = "unload_timeout", _("Nobody unloaded a robot waiting at a drop-off")
    UNATTENDED = "unattended", _("Robot moved on from a drop-off nobody unloaded")
    DEADLINE_AT_RISK = "deadline_at_risk", _("Delivery will be late")
    RESOURCE_OUT_OF_SERVICE = (
        "resource_out_of_service",
        _("Elevator, door or corridor out of service"),
    )
    FIRE_ALARM = "fire_alarm", _("Fire alarm: robots stopped, no lift granted, deliveries held")
    ROBOT_STUCK = "robot_stuck", _("Robot reports moving but makes no progress")
    LIFT_CAR_MISSING = "lift_car_missing", _("Robot held at a lift whose car does not come")
    LIFT_PRIORITY = "lift_priority", _("Lift held for an emergency team: no robot is granted it")
    LEASE_DEADLOCK = "lease_deadlock", _("Robots waiting for each other's resources")


class AlertQuerySet(models.QuerySet):
    def open(self):
        return self.filter(acknowledged_at__isnull=True)


class Alert(models.Model):
    """Something an operator must see and acknowledge; shown on every page until then."""

    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="alerts")
    kind = models.CharField(max_length=32, choices=AlertKind)
    key = models.CharField(
        max_length=200, help_text="one open alert per key: raising it again changes nothing"
    )
    message = models.TextField(help_text="in English, for the API, webhooks and logs")
    words = models.JSONField(
        null=True, blank=True, help_text="the message to show in each reader's language (core/said)"
    )
    robot = models.ForeignKey(Robot, null=True, blank=True, on_delete=models.SET_NULL)
    resource = models.ForeignKey(Resource, null=True, blank=True, on_delete=models.SET_NULL)
    task = models.CharField(max_length=32, blank=True, help_text="task code, if about one")
    raised_at = models.DateTimeField(default=timezone.now)
    acknowledged_at = models.DateTimeField(null=True, blank=True)
    acknowledged_by = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL
    )

    objects = AlertQuerySet.as_manager()

    class Meta:
        ordering = ["-raised_at", "-id"]
        constraints = [
            models.UniqueConstraint(
                fields=["key"], condition=Q(acknowledged_at__isnull=True), name="alert_open_key"
            ),
        ]

    def __str__(self):
        return f"{self.get_kind_display()}: {self.message}"

    @property
    def text(self) -> str:
        """The message in the reader's language."""
        return said_text(self.words, self.message)
