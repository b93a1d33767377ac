from django.db import models


class Source(models.TextChoices):
    """Where a user's identity comes from, and so where their password is checked."""

    LOCAL = "local", "local"  # a password kept here: break-glass administrators, the demo
    LDAP = "ldap", "LDAP directory"
    OIDC = "oidc", "single sign-on"


class Role(models.TextChoices):
    """What a directory group may give (ROLE_GROUPS). Nurse and operator are the page groups of
    core.access; an administrator is a staff user and superuser (the Django admin, the maps)."""

    NURSE = "nurse", "nurse"
    OPERATOR = "operator", "operator"
    ADMIN = "admin", "administrator"
    AUDITOR = "auditor", "auditor"  # core.access.AUDITOR: reads the audit trail of its sites
