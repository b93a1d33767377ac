"""Emergency modes of a site: a fire alarm, from its start to the all-clear.

The row keeps who started and ended it and which robots it stopped, so the all-clear resumes
those and no other. Site.fire_alarm_since mirrors the open row: the allocator and the lease
controller read the site row they already hold instead of querying this table.
"""

from django.conf import settings
from django.db import models
from django.db.models import Q

from robots.choices import EmergencyKind, EmergencySource
from robots.models.map import Site


class EmergencyQuerySet(models.QuerySet):
    def active(self):
        return self.filter(ended_at__isnull=True)


class Emergency(models.Model):
    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="emergencies")
    kind = models.CharField(max_length=16, choices=EmergencyKind, default=EmergencyKind.FIRE_ALARM)
    floors = models.JSONField(
        default=list, blank=True, help_text="floor codes it covers; empty: every floor"
    )
    reason = models.CharField(max_length=200, blank=True)
    started_at = models.DateTimeField()
    started_by = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    started_via = models.CharField(max_length=16, choices=EmergencySource)
    ended_at = models.DateTimeField(null=True, blank=True)
    ended_by = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    ended_via = models.CharField(max_length=16, choices=EmergencySource, blank=True)
    stopped_robots = models.JSONField(
        default=list, blank=True, help_text="codes of the robots it paused, resumed at its end"
    )
    refuges = models.JSONField(
        default=dict,
        blank=True,
        help_text="robot code -> the refuge point it was sent to, replanned at its end",
    )

    objects = EmergencyQuerySet.as_manager()

    class Meta:
        ordering = ["-started_at", "-id"]
        constraints = [
            models.UniqueConstraint(
                fields=["site", "kind"],
                condition=Q(ended_at__isnull=True),
                name="emergency_one_active_per_site",
            ),
        ]

    def __str__(self):
        where = ", ".join(self.floors) if self.floors else "every floor"
        return f"{self.get_kind_display()} at {self.site_id} ({where})"

    def covers(self, floor_code: str | None) -> bool:
        """Whether a robot on `floor_code` (None: not known) is in the alarm's area."""
        return not self.floors or floor_code is None or floor_code in self.floors
