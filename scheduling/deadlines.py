"""When a delivery is due, and how late its estimate says it will be. Pure reads."""

from datetime import datetime, timedelta

from django.utils import timezone, translation
from django.utils.translation import gettext_noop

from core.said import Said
from robots.models import Site
from scheduling.choices import PRIORITY_ALIASES, Priority


def priority_of(name: str) -> str:
    """The priority a name stands for, old names (`normal`) included."""
    return PRIORITY_ALIASES.get(name, name)


def due_at_default(*, site: Site, priority: str, requested_time: datetime) -> datetime:
    """The site's due-by time for a request of this priority made for `requested_time`."""
    minutes = {
        Priority.STAT: site.stat_due_minutes,
        Priority.URGENT: site.urgent_due_minutes,
    }.get(priority, site.routine_due_minutes)
    return requested_time + timedelta(minutes=minutes)


def late_by(*, eta: datetime | None, due_at: datetime | None) -> timedelta | None:
    """How long after its due-by time the estimate drops it off; None if on time or unknown."""
    if eta is None or due_at is None or eta <= due_at:
        return None
    return eta - due_at


def lateness_note(*, eta: datetime | None, due_at: datetime | None) -> str:
    """ "earliest drop-off 14:32, 7 min after it is due", or "" if on time (site local time)."""
    said = lateness_said(eta=eta, due_at=due_at)
    return str(said) if said else ""


def lateness_said(*, eta: datetime | None, due_at: datetime | None) -> Said | None:
    """The lateness note as words for any reader's language; None if on time."""
    late = late_by(eta=eta, due_at=due_at)
    if late is None:
        return None
    return Said(
        gettext_noop("earliest drop-off %(time)s, %(minutes)s min after it is due"),
        time=f"{timezone.localtime(eta):%H:%M}",
        minutes=max(1, round(late.total_seconds() / 60)),
    )


def priority_said(priority: str) -> Said:
    """A priority's name (its label's English is the catalog's msgid) for any language."""
    with translation.override("en"):
        return Said(str(Priority(priority).label))
