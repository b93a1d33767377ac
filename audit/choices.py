from django.db import models
from django.utils.translation import gettext_lazy as _


class Kind(models.TextChoices):
    """What an audit entry records. Model changes come from django-auditlog (CHANGE, with its
    create/update/delete action); the others are written by the services that do them."""

    CHANGE = "change", _("record changed")
    SIGN_IN = "sign_in", _("signed in")
    SIGN_IN_FAILED = "sign_in_failed", _("sign-in failed")
    SIGN_OUT = "sign_out", _("signed out")
    LOCKED_OUT = "locked_out", _("locked out")
    TOKEN_ISSUED = "token_issued", _("token issued")
    TASK_ORDERED = "task_ordered", _("delivery ordered")
    TASK_CANCELLED = "task_cancelled", _("delivery cancelled")
    OPERATOR_ACTION = "operator_action", _("operator action")
    LEASE_FORCE_RELEASED = "lease_force_released", _("lift or door force-released")
    MAP_PUBLISHED = "map_published", _("map published")
    CUSTODY_EXPORTED = "custody_exported", _("custody exported")
    ORDER_READ = "order_read", _("patient-linked order read")
    AUDIT_EXPORTED = "audit_exported", _("audit trail exported")
    RETENTION_SWEEP = "retention_sweep", _("old entries removed")
