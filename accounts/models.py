"""Where each user comes from, their workstation PIN, and the shared ward workstations."""

from django.conf import settings
from django.contrib.auth.hashers import check_password
from django.core.exceptions import ValidationError
from django.db import models

from accounts.choices import Source
from robots.choices import WaypointKind


class Account(models.Model):
    """What the sign-in knows of a user beyond Django's User: where the identity comes from (a
    user without this row is local) and the hash of the PIN they confirm orders with at a
    shared workstation, with their badge."""

    user = models.OneToOneField(
        settings.AUTH_USER_MODEL, on_delete=models.CASCADE, primary_key=True, related_name="account"
    )
    source = models.CharField(max_length=8, choices=Source.choices, default=Source.LOCAL)
    # The directory's name for the user: the DN in LDAP, the `sub` claim in single sign-on. A
    # directory user is found by it, never by a username another source could have taken.
    subject = models.CharField(max_length=500, blank=True)
    synced_at = models.DateTimeField(
        null=True, blank=True, help_text="the last sign-in that applied the directory's groups"
    )
    # Django's password hash of the PIN (salted, slow; never the PIN): it never leaves the
    # server, unlike a badge's hash, which robots check offline (robots/badges.py).
    pin_hash = models.CharField(max_length=256, blank=True, editable=False)
    # The pages' language the person chose (a code of settings.LANGUAGES); empty: their browser's.
    language = models.CharField(max_length=8, blank=True)

    class Meta:
        constraints = [
            models.UniqueConstraint(
                fields=["source", "subject"],
                condition=~models.Q(subject=""),
                name="account_subject_once_per_source",
            ),
        ]

    def __str__(self):
        return f"{self.user} ({self.get_source_display()})"

    def pin_matches(self, pin: str) -> bool:
        return bool(self.pin_hash) and check_password(pin, self.pin_hash)


class Workstation(models.Model):
    """A shared PC at a ward's nurses' station: a local account that stays signed in on it,
    bound to a site and a unit. It may not order by itself; each order there is confirmed by a
    person (badge and PIN, or their own password) and placed in that person's name."""

    user = models.OneToOneField(
        settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="workstation"
    )
    site = models.ForeignKey("robots.Site", on_delete=models.CASCADE, related_name="workstations")
    unit = models.ForeignKey(
        "robots.Waypoint",
        on_delete=models.PROTECT,
        related_name="workstations",
        limit_choices_to={"kind": WaypointKind.STATION},
        help_text="the station of the ward the workstation stands at",
    )
    name = models.CharField(max_length=100, help_text="as the page shows it, e.g. Ward 3 desk")

    def __str__(self):
        return self.name

    def clean(self):
        errors = {}
        unit = self.unit if self.unit_id else None
        if unit and (unit.site_id != self.site_id or unit.kind != WaypointKind.STATION):
            errors["unit"] = "a station of the workstation's site"
        if self.user_id and (self.user.is_staff or self.user.groups.exists()):
            errors["user"] = (
                "a workstation's account has no role of its own (no staff status, no group): "
                "use an account made for the workstation"
            )
        if errors:
            raise ValidationError(errors)
