"""Daily roll-ups: each closed day's figures (reports/selectors.py) stored once the day is
settled, so that a report over a year adds up 365 stored days and computes only the rest
(today, and days not settled yet) from the histories.

A day is settled when it ended SETTLE ago and nothing requested in it can change its figures
any more: every task requested that day finished (completed, cancelled or failed) and every
lease requested that day was granted or ended. Everything else a day's figures count
(transitions, robot activity, alerts) is written at the time it happens, never into a past
day, so a stored day never goes stale and nothing has to invalidate it. A day that does not
settle (a task left open) is simply computed live whenever a report covers it.

The sweep (Celery beat, reports.tasks.rollup_sweep) stores the settled days of the last
LONGEST report's days, newest first, at most DAYS_PER_SWEEP a run, so a first run on a long
history catches up over a few minutes without one long run.
"""

from datetime import date, datetime, timedelta

from django.utils import timezone

from reports.forms import LONGEST
from reports.histograms import figures_add
from reports.models import DailyRollup
from reports.selectors import FIGURES, Period, period_partials
from resources.models import Lease
from robots.models import Site
from scheduling.choices import FINISHED_STATUSES
from scheduling.models import Task

SETTLE = timedelta(minutes=10)  # transactions that began before midnight have committed
DAYS_PER_SWEEP = 31


def period_figures(
    period: Period, *, now: datetime, names: list[str] | None = None
) -> dict[str, dict]:
    """The figures' partials over the period (every figure, or those `names`): stored days
    added up, the others computed."""
    names = names or list(FIGURES)
    total: dict[str, dict] = {}
    stored = DailyRollup.objects.filter(
        site=period.site, day__gte=period.first, day__lte=period.last
    )
    rolled_up = set()
    # Only the figures asked for leave the database (a CSV needs one of seven).
    for day, *figures in stored.values_list("day", *(f"figures__{name}" for name in names)):
        figures_add(total, dict(zip(names, (figure or {} for figure in figures), strict=True)))
        rolled_up.add(day)
    for first, last in _runs([day for day in period.days if day not in rolled_up]):
        live = Period(site=period.site, first=first, last=last)
        figures_add(total, period_partials(live, now=now, names=names))
    return total


def _runs(days: list[date]) -> list[tuple[date, date]]:
    """Consecutive days as (first, last) runs, each computed in one go."""
    runs: list[tuple[date, date]] = []
    for day in days:
        if runs and runs[-1][1] + timedelta(days=1) == day:
            runs[-1] = (runs[-1][0], day)
        else:
            runs.append((day, day))
    return runs


def rollup_sweep(*, now: datetime) -> int:
    """Store the settled days not stored yet, for every site; how many were stored."""
    return sum(site_rollup(site=site, now=now) for site in Site.objects.order_by("pk"))


def site_rollup(*, site: Site, now: datetime) -> int:
    today = timezone.localdate(now)
    window = [today - timedelta(days=n) for n in range(1, LONGEST.days + 2)]
    stored = set(
        DailyRollup.objects.filter(site=site, day__gte=window[-1]).values_list("day", flat=True)
    )
    missing = [day for day in window if day not in stored]
    rollups = []
    for day in missing:
        if len(rollups) == DAYS_PER_SWEEP:
            break
        period = Period(site=site, first=day, last=day)
        if _settled(period, now=now):
            figures = period_partials(period, now=now)
            rollups.append(DailyRollup(site=site, day=day, figures=figures, computed_at=now))
    # Two sweeps at once store the same figures: the second one's rows are simply dropped.
    DailyRollup.objects.bulk_create(rollups, ignore_conflicts=True)
    return len(rollups)


def _settled(period: Period, *, now: datetime) -> bool:
    if period.end + SETTLE > now:
        return False
    open_tasks = Task.objects.filter(
        site=period.site, requested_time__gte=period.start, requested_time__lt=period.end
    ).exclude(status__in=FINISHED_STATUSES)
    waiting_leases = Lease.objects.filter(
        resource__site=period.site,
        requested_at__gte=period.start,
        requested_at__lt=period.end,
        granted_at__isnull=True,
        ended_at__isnull=True,
    )
    return not open_tasks.exists() and not waiting_leases.exists()
