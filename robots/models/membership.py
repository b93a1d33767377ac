"""Who works at which site: users see and act on their sites only (robots/membership.py)."""

from django.conf import settings
from django.db import models


class SiteMembership(models.Model):
    """A user of the pages works at a site: pages, sockets and actions show and touch only the
    sites the user belongs to (staff users and superusers: every site; robots/membership.py)."""

    user = models.ForeignKey(
        settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="site_memberships"
    )
    site = models.ForeignKey("robots.Site", on_delete=models.CASCADE, related_name="memberships")

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["user", "site"], name="site_membership_once"),
        ]

    def __str__(self):
        return f"{self.user} at {self.site}"
