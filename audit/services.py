"""Writing the audit trail: one entry per security-relevant event, and the retention sweep.

The request that caused an event is not passed down to the services that record it: its user
and client address are read when the entry is written (audit/context.py, set for every request
by audit.middleware.AuditContextMiddleware, and by `acting` for work done outside a request).
"""

from datetime import datetime, timedelta

from django.conf import settings
from django.contrib.contenttypes.models import ContentType
from django.db import transaction

from audit import chain
from audit.choices import Kind
from audit.context import current_actor
from audit.models import AuditEntry, ChainHead, site_of


def entry_record(
    *,
    kind: Kind,
    obj=None,
    model=None,
    object_repr: str | None = None,
    actor=None,
    actor_name: str = "",
    site_id: int | None = None,
    changes: dict | None = None,
    data: dict | None = None,
) -> AuditEntry:
    """One audit entry about `obj` (or, with no object, about an instance of `model`).

    The actor is `actor`, else the request's user; `actor_name` names someone who is not a
    user (a failed sign-in's username, a robot). `changes` is a before/after per field,
    {"field": [before, after]}; `data` anything else worth keeping (what was exported).
    """
    model = model or type(obj)
    signed_in = current_actor()
    if actor is not None and signed_in is not None and signed_in.pk != actor.pk:
        # A person acting at a shared workstation: the account signed in is the workstation.
        data = {**(data or {}), "signed_in_as": signed_in.get_username()}
    entry = AuditEntry(
        kind=kind,
        action=AuditEntry.Action.ACCESS if changes is None else AuditEntry.Action.UPDATE,
        content_type=ContentType.objects.get_for_model(model),
        object_pk=str(obj.pk) if obj is not None else "",
        object_id=obj.pk if obj is not None and isinstance(obj.pk, int) else None,
        object_repr=object_repr if object_repr is not None else str(obj or ""),
        actor=actor,
        actor_name=actor.get_username() if actor is not None else actor_name,
        site_id=site_id if site_id is not None else (site_of(obj) if obj is not None else None),
        changes=changes,
        additional_data=data,
    )
    entry.save()
    return entry


def custody_export_record(*, site, start, end, rows: int) -> AuditEntry:
    """Who exported a site's chain of custody, for which days, and how many hand-offs."""
    return entry_record(
        kind=Kind.CUSTODY_EXPORTED,
        obj=site,
        object_repr=f"custody of {site.code}, {start.isoformat()} to {end.isoformat()}",
        data={"from": start.isoformat(), "to": end.isoformat(), "rows": rows},
    )


def audit_export_record(*, filters: dict, rows: int, file_format: str) -> AuditEntry:
    """Who exported which part of the audit trail: auditors' reads are audited too."""
    site = filters.get("site")
    described = {
        name: value.isoformat() if hasattr(value, "isoformat") else value
        for name, value in filters.items()
        if name != "site" and value
    }
    return entry_record(
        kind=Kind.AUDIT_EXPORTED,
        model=AuditEntry,
        site_id=site.pk if site is not None else None,
        object_repr=f"{rows} entries as {file_format.upper()}",
        data={**described, "site": site.code if site else "", "rows": rows},
    )


@transaction.atomic
def entries_sweep(*, now: datetime) -> int:
    """Remove the entries older than AUDIT_RETENTION_DAYS (0: keep them all), and record what
    was removed as an entry of its own. The chain then starts at the oldest entry kept, whose
    previous hash that entry names, so audit_verify still checks every entry that is left."""
    days = settings.AUDIT_RETENTION_DAYS
    if days == 0:
        return 0
    cutoff = now - timedelta(days=days)
    old = AuditEntry.objects.filter(timestamp__lt=cutoff)
    if not old.exists():
        return 0
    ChainHead.locked()  # no entry is written while old ones go
    last = old.order_by("id").values("id", "entry_hash", "timestamp").last()
    removed = AuditEntry.objects.filter(id__lte=last["id"])
    first = removed.order_by("id").values("id", "timestamp").first()
    count, _by_model = removed.delete()  # one DELETE: nothing refers to entries
    entry_record(
        kind=Kind.RETENTION_SWEEP,
        model=AuditEntry,
        object_repr=f"{count} entries older than {days} days",
        actor_name="retention sweep",
        data={
            "removed": count,
            "first_id": first["id"],
            "last_id": last["id"],
            "last_hash": last["entry_hash"],
            "oldest": first["timestamp"].isoformat(),
            "newest": last["timestamp"].isoformat(),
            "retention_days": days,
        },
    )
    return count


def chain_anchor() -> str:
    """The previous hash the oldest kept entry must carry: that of the last entry a retention
    sweep removed, or the genesis value if none was ever removed."""
    sweep = (
        AuditEntry.objects.filter(kind=Kind.RETENTION_SWEEP)
        .order_by("-id")
        .values_list("additional_data", flat=True)
        .first()
    )
    return sweep["last_hash"] if sweep else chain.GENESIS
