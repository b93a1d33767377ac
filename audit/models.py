"""The audit trail: one append-only table of who did what, when, from where, and to what.

AuditEntry is django-auditlog's log entry (settings.AUDITLOG_LOGENTRY_MODEL), so the model
changes it records (users, groups, site memberships, tokens, webhooks, sites and resources) and
the events the services record (sign-ins, cancels, exports, reads of patient-linked orders...)
share one table, one chain (audit/chain.py) and one page.
"""

import ipaddress

from auditlog.models import AbstractLogEntry, LogEntryManager
from django.db import models, transaction

from audit import chain
from audit.choices import Kind
from audit.context import current_actor, current_address


class EntryNotEditable(Exception):
    """Audit entries are written once; only the retention sweep removes them."""


def site_of(instance) -> int | None:
    """The site a changed record belongs to (a site itself is its own)."""
    if instance._meta.label == "robots.Site":
        return instance.pk
    return getattr(instance, "site_id", None)


class AuditEntryManager(LogEntryManager):
    """django-auditlog's manager; model changes are filed under the changed record's site."""

    def log_create(self, instance, force_log: bool = False, **kwargs):
        kwargs.setdefault("site_id", site_of(instance))
        return super().log_create(instance, force_log=force_log, **kwargs)

    def log_m2m_changes(self, changed_queryset, instance, operation, field_name, **kwargs):
        kwargs.setdefault("site_id", site_of(instance))
        return super().log_m2m_changes(changed_queryset, instance, operation, field_name, **kwargs)


class AuditEntry(AbstractLogEntry):
    kind = models.CharField(max_length=24, choices=Kind, default=Kind.CHANGE)
    # The site the entry concerns, by id: it stays when the site is deleted (no constraint).
    site = models.ForeignKey(
        "robots.Site",
        null=True,
        blank=True,
        on_delete=models.DO_NOTHING,
        db_constraint=False,
        related_name="+",
    )
    # The actor's username when the entry was written: it stays when the user is deleted or
    # renamed (the actor column is then NULL or names the new name).
    actor_name = models.CharField(max_length=150, blank=True)
    previous_hash = models.CharField(max_length=64, blank=True, editable=False)
    entry_hash = models.CharField(max_length=64, blank=True, editable=False)

    objects = AuditEntryManager()

    class Meta(AbstractLogEntry.Meta):
        verbose_name = "audit entry"
        verbose_name_plural = "audit entries"
        ordering = ["-id"]
        indexes = [
            models.Index(fields=["site", "timestamp"], name="audit_site_time"),
            models.Index(fields=["kind", "timestamp"], name="audit_kind_time"),
            models.Index(fields=["actor_name", "timestamp"], name="audit_actor_time"),
        ]

    def __str__(self):
        return f"#{self.pk} {self.get_kind_display()}: {self.object_repr}"

    def save(self, *args, **kwargs):
        if not self._state.adding:
            raise EntryNotEditable(f"audit entry #{self.pk} cannot be changed")
        # No savepoint: an entry is written inside the caller's transaction and goes (or stays)
        # with it; two statements fewer on every audited action.
        with transaction.atomic(savepoint=False):
            head = ChainHead.locked()
            self._seal(previous=head.last_hash)
            super().save(*args, **kwargs)
            head.advance(self)

    def delete(self, *args, **kwargs):
        raise EntryNotEditable(f"audit entry #{self.pk} cannot be deleted")

    def _seal(self, *, previous: str) -> None:
        if self.actor_id is None and not self.actor_name:
            self.actor = current_actor()
        if self.actor_id and not self.actor_name:
            self.actor_name = self.actor.get_username()
        self.remote_addr = _address(self.remote_addr or current_address())
        self.object_pk = str(self.object_pk)  # as it reads back, so that the hash matches
        self.previous_hash = previous
        self.entry_hash = chain.hash_of(self)


def _address(value) -> str | None:
    try:
        return str(ipaddress.ip_address(value)) if value else None
    except ValueError:
        return None


class ChainHead(models.Model):
    """One row: the newest entry and its hash. Locked by every write of an entry, so entries
    are chained in one order, and compared by audit_verify with the newest entry, so that
    entries removed from the end show."""

    last_entry_id = models.BigIntegerField(null=True)
    last_hash = models.CharField(max_length=64, blank=True)

    def __str__(self):
        return f"audit chain head: #{self.last_entry_id}"

    @classmethod
    def locked(cls) -> "ChainHead":
        head = cls.objects.select_for_update().filter(pk=1).first()
        return head or cls.objects.create(pk=1, last_hash=chain.GENESIS)

    def advance(self, entry: AuditEntry) -> None:
        self.last_entry_id, self.last_hash = entry.pk, entry.entry_hash
        self.save(update_fields=["last_entry_id", "last_hash"])
