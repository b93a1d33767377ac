from django.db import models


class Kind(models.TextChoices):
    """What an audit entry records. Model changes come from django-auditlog (CHANGE, with its
    create/update/delete action); the others are written by the services that do them."""

    CHANGE = "change", "record changed"
    SIGN_IN = "sign_in", "signed in"
    SIGN_IN_FAILED = "sign_in_failed", "sign-in failed"
    SIGN_OUT = "sign_out", "signed out"
    LOCKED_OUT = "locked_out", "locked out"
    TOKEN_ISSUED = "token_issued", "token issued"
    TASK_ORDERED = "task_ordered", "delivery ordered"
    TASK_CANCELLED = "task_cancelled", "delivery cancelled"
    OPERATOR_ACTION = "operator_action", "operator action"
    LEASE_FORCE_RELEASED = "lease_force_released", "lift or door force-released"
    MAP_PUBLISHED = "map_published", "map published"
    CUSTODY_EXPORTED = "custody_exported", "custody exported"
    ORDER_READ = "order_read", "patient-linked order read"
    AUDIT_EXPORTED = "audit_exported", "audit trail exported"
    RETENTION_SWEEP = "retention_sweep", "old entries removed"
