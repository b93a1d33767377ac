"""Who works at which site: users see and act on their sites only (robots/membership.py)."""

from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import models

from robots.badges import BadgeHash
from robots.choices import WaypointKind


class SiteMembership(models.Model):
    """A user of the pages works at a site: pages, sockets and actions show and touch only the
    sites the user belongs to (staff users and superusers: every site; robots/membership.py)."""

    user = models.ForeignKey(
        settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="site_memberships"
    )
    site = models.ForeignKey("robots.Site", on_delete=models.CASCADE, related_name="memberships")
    # The unit (ward, laboratory...) the user works at, by its station: its users may open a
    # secure delivery to that station with their badge (robots/badges.py: only its hash kept).
    unit = models.ForeignKey(
        "robots.Waypoint",
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="members",
        limit_choices_to={"kind": WaypointKind.STATION},
        help_text="the station of the user's unit",
    )
    badge_salt = models.CharField(max_length=64, blank=True, editable=False)
    badge_iterations = models.PositiveIntegerField(default=0, editable=False)
    badge_hash = models.CharField(max_length=128, blank=True, editable=False)

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["user", "site"], name="site_membership_once"),
        ]

    def __str__(self):
        return f"{self.user} at {self.site}"

    def clean(self):
        if self.unit_id is None or self.site_id is None:
            return
        if self.unit.site_id != self.site_id or self.unit.kind != WaypointKind.STATION:
            raise ValidationError({"unit": "a station of the membership's site"})

    @property
    def badge(self) -> BadgeHash | None:
        """The hash of the user's badge, if one is set."""
        if not self.badge_hash:
            return None
        salt, iterations = self.badge_salt, self.badge_iterations
        return BadgeHash(salt=salt, iterations=iterations, hash=self.badge_hash)
