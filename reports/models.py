from django.db import models
from django.utils import timezone

from robots.models import Site


class DailyRollup(models.Model):
    """A site's report figures for one closed day (in the site's time zone), stored once nothing
    requested that day can change any more (reports/rollups.py), so that a report over a year
    reads 365 of these instead of a year of histories. Days without one are computed live."""

    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="+")
    day = models.DateField()
    # {figure: its mergeable partial} as reports/selectors.py computes them for the day
    figures = models.JSONField()
    computed_at = models.DateTimeField(default=timezone.now)

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["site", "day"], name="rollup_one_per_site_day"),
        ]

    def __str__(self):
        return f"{self.site.code} {self.day}"
