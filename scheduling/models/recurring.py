"""Periodic delivery requests: a template and a schedule that create task instances."""

from django.conf import settings
from django.db import models
from django.utils import timezone

from scheduling.choices import Priority


class RecurringRequest(models.Model):
    """Every day at fixed times, or every N minutes within a daily window (site local time).

    `repeat` is {"times": ["08:00", ...]} or {"every_minutes": N, "from": "08:00",
    "until": "20:00"}; instances are created once per occurrence (scheduling.recurrence).
    """

    site = models.ForeignKey("robots.Site", on_delete=models.PROTECT, related_name="+")
    requester = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL
    )
    sender = models.CharField(max_length=200)
    receiver = models.CharField(max_length=200)
    contents = models.CharField(max_length=200)
    priority = models.CharField(max_length=8, choices=Priority, default=Priority.ROUTINE)
    pickups = models.JSONField(help_text="station codes")
    dropoffs = models.JSONField(help_text="station codes")
    repeat = models.JSONField()
    starts_at = models.DateTimeField(help_text="no occurrence before this")
    active = models.BooleanField(default=True)
    created_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["id"]

    def __str__(self):
        return f"{self.contents}: {', '.join(self.pickups)} -> {', '.join(self.dropoffs)}"
