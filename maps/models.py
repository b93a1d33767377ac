"""A site's map as an administrator edits it: one draft per site and every published version.

Both hold a whole site file (robot-protocol.md, "Site description file") as JSON, so the draft
is validated by the site file's own rules, a version exports as the file `load_site` reads, and
publishing goes through the same loader (robots/sitefile.py).
"""

from django.conf import settings
from django.db import models
from django.utils import timezone

from maps.choices import Rollout


class MapDraft(models.Model):
    """The draft of a site's next map, and the site's choice of how it is rolled out."""

    site = models.OneToOneField(
        "robots.Site", primary_key=True, on_delete=models.CASCADE, related_name="map_draft"
    )
    document = models.JSONField(help_text="a whole site file; may be invalid while edited")
    revision = models.PositiveIntegerField(
        default=1, help_text="raised by every save; a save must name the one it edited"
    )
    base_version = models.PositiveIntegerField(help_text="the map version the draft started from")
    rollout = models.CharField(max_length=16, choices=Rollout, default=Rollout.REFUSE)
    updated_at = models.DateTimeField(default=timezone.now)
    updated_by = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )

    def __str__(self):
        return f"draft of {self.site_id} (revision {self.revision})"


class MapVersion(models.Model):
    """A published map: the site file as it was applied, who published it, when and why."""

    site = models.ForeignKey("robots.Site", on_delete=models.CASCADE, related_name="map_versions")
    number = models.PositiveIntegerField(help_text="the site's map_version once it was applied")
    document = models.JSONField()
    author = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    published_at = models.DateTimeField(default=timezone.now)
    note = models.CharField(max_length=500, blank=True)
    restored_from = models.PositiveIntegerField(
        null=True, blank=True, help_text="a rollback: the number of the version published again"
    )
    replanned = models.JSONField(default=list, help_text="robots re-planned by the publication")

    class Meta:
        ordering = ["site", "-number"]
        constraints = [
            models.UniqueConstraint(fields=["site", "number"], name="map_version_unique_in_site"),
        ]

    def __str__(self):
        return f"{self.site_id} map version {self.number}"
