from django.db import models
from django.utils.translation import gettext_lazy as _


class Source(models.TextChoices):
    """Where a user's identity comes from, and so where their password is checked."""

    LOCAL = "local", "local"  # a password kept here: break-glass administrators, the demo
    LDAP = "ldap", _("LDAP directory")
    OIDC = "oidc", _("single sign-on")


class Role(models.TextChoices):
    """What a directory group may give (ROLE_GROUPS). Nurse and operator are the page groups of
    core.access; an administrator is a staff user and superuser (the Django admin, the maps)."""

    NURSE = "nurse", _("nurse")
    OPERATOR = "operator", _("operator")
    ADMIN = "admin", _("administrator")
    AUDITOR = "auditor", "auditor"  # core.access.AUDITOR: reads the audit trail of its sites
