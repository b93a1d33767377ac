"""Reads of the audit trail for the auditors' page and its exports."""

from dataclasses import dataclass
from datetime import date, datetime, time, timedelta

from django.db.models import Q, QuerySet
from django.utils import timezone

from audit.choices import Kind
from audit.models import AuditEntry
from robots.membership import member_site_ids
from robots.models import Site

# Entries about a person who did not act: failed sign-ins and lock-outs name the user tried.
ABOUT_A_NAME = (Kind.SIGN_IN_FAILED, Kind.LOCKED_OUT)


def entries_visible(user) -> QuerySet[AuditEntry]:
    """What `user` may read: every entry for staff; an auditor, the entries of their sites
    (entries of no site, such as sign-ins and changes of users, only for staff)."""
    entries = AuditEntry.objects.select_related("content_type", "site")
    sites = member_site_ids(user)
    return entries if sites is None else entries.filter(site_id__in=sites)


def sites_visible(user) -> QuerySet[Site]:
    sites = member_site_ids(user)
    every = Site.objects.order_by("code")
    return every if sites is None else every.filter(pk__in=sites)


def entries_matching(
    entries: QuerySet[AuditEntry],
    *,
    person: str = "",
    site: Site | None = None,
    kind: str = "",
    start: date | None = None,
    end: date | None = None,
) -> QuerySet[AuditEntry]:
    """Filtered by who acted (or whose name was tried), site, kind and days (both included,
    in the site's time zone), newest first."""
    if person:
        entries = entries.filter(
            Q(actor_name=person) | Q(kind__in=ABOUT_A_NAME, object_repr=person)
        )
    if site is not None:
        entries = entries.filter(site=site)
    if kind:
        entries = entries.filter(kind=kind)
    if start is not None:
        entries = entries.filter(timestamp__gte=_midnight(start))
    if end is not None:
        entries = entries.filter(timestamp__lt=_midnight(end + timedelta(days=1)))
    return entries.order_by("-id")


def _midnight(day: date) -> datetime:
    return datetime.combine(day, time.min, timezone.get_current_timezone())


@dataclass(frozen=True)
class SignIns:
    """A user's previous sign-in and the failed ones with their name since."""

    last_at: datetime | None
    last_address: str
    failures_since: int


def sign_ins_of(user) -> SignIns:
    """Two indexed reads (actor_name, kind and time)."""
    name = user.get_username()
    last = (
        AuditEntry.objects.filter(kind=Kind.SIGN_IN, actor_name=name)
        .order_by("-id")
        .values("id", "timestamp", "remote_addr")
        .first()
    )
    failed = AuditEntry.objects.filter(kind__in=ABOUT_A_NAME, object_repr=name)
    if last is not None:
        failed = failed.filter(id__gt=last["id"])
    return SignIns(
        last_at=last["timestamp"] if last else None,
        last_address=(last["remote_addr"] or "") if last else "",
        failures_since=failed.count(),
    )
