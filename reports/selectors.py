"""The reports' figures for a site over a span of time, each computed by the database in
aggregate queries over the stored histories (tasks and their stops and transitions, the robots'
activity, leases, alerts), indexed on the site and time of each.

Each figure is a mergeable partial: counts, sums of seconds and histograms of durations
(reports/histograms.py), so that the partials of consecutive days added together are the
figure over those days. reports/rollups.py stores closed days' partials and adds them up for a
period; reports/tables.py turns the sum into the rows of each table, chart and CSV.
"""

from collections import defaultdict
from dataclasses import dataclass
from datetime import date, datetime, time, timedelta
from zoneinfo import ZoneInfo

from django.conf import settings
from django.db import connection
from django.db.models import Count, F, Q, Value
from django.db.models.functions import Coalesce, Concat, ExtractHour, NullIf, Round, TruncDate

from reports.aggregates import Seconds
from resources.models import Lease
from robots.models import Alert, AlertKind, Robot, RobotActivity, Site
from scheduling.choices import StopAction, TaskStatus
from scheduling.models import Task, TaskStop, TaskTransition

# Histogram bucket widths (seconds): turnarounds are shown in tenths of a minute, waits in
# tenths of a second; a percentile is within half a bucket of the exact one.
TURNAROUND_WIDTH = 1.0
WAIT_WIDTH = 0.1


@dataclass(frozen=True)
class Period:
    """Days `first`..`last` (inclusive) in the site's time zone, as aware datetimes."""

    site: Site
    first: date
    last: date

    @property
    def zone(self) -> ZoneInfo:
        return ZoneInfo(settings.TIME_ZONE)

    @property
    def start(self) -> datetime:
        return datetime.combine(self.first, time.min, tzinfo=self.zone)

    @property
    def end(self) -> datetime:
        return datetime.combine(self.last + timedelta(days=1), time.min, tzinfo=self.zone)

    @property
    def days(self) -> list[date]:
        return [self.first + timedelta(days=n) for n in range((self.last - self.first).days + 1)]


def period_partials(
    period: Period, *, now: datetime, names: list[str] | None = None
) -> dict[str, dict]:
    """The figures' partials (every figure, or those `names`) over the whole period, straight
    from the histories."""
    return {name: FIGURES[name](period, now=now) for name in names or FIGURES}


def _tasks(period: Period):
    return Task.objects.filter(
        site=period.site, requested_time__gte=period.start, requested_time__lt=period.end
    ).order_by()


def deliveries_per_day(period: Period, *, now: datetime) -> dict[str, int]:
    """{day: deliveries requested that day}."""
    rows = (
        _tasks(period)
        .annotate(day=TruncDate("requested_time", tzinfo=period.zone))
        .values("day")
        .annotate(n=Count("pk"))
    )
    return {row["day"].isoformat(): row["n"] for row in rows}


def deliveries_per_hour(period: Period, *, now: datetime) -> dict[str, int]:
    """{hour of day: deliveries requested in that hour}."""
    rows = (
        _tasks(period)
        .annotate(hour=ExtractHour("requested_time", tzinfo=period.zone))
        .values("hour")
        .annotate(n=Count("pk"))
    )
    return {str(row["hour"]): row["n"] for row in rows}


def turnaround_by_priority(period: Period, *, now: datetime) -> dict[str, dict]:
    """Per priority: deliveries, cancelled, those with a due time and not cancelled ("due"),
    those delivered by it (`Task.due_at`, the request's own or its priority's at the site;
    tasks from before deadlines existed have none and count in neither), and histograms of
    request -> pick-up and request -> drop-off."""
    figures = {
        "deliveries": Count("pk"),
        "cancelled": Count("pk", filter=Q(status=TaskStatus.CANCELLED)),
        "due": Count("pk", filter=Q(due_at__isnull=False) & ~Q(status=TaskStatus.CANCELLED)),
        "on_time": Count("pk", filter=Q(delivered_at__lte=F("due_at"))),
    }
    durations = {
        "pickup": Seconds("picked_up_at", "requested_time"),
        "dropoff": Seconds("delivered_at", "requested_time"),
    }
    return _turnaround(_tasks(period), "priority", figures, durations)


def turnaround_by_ward(period: Period, *, now: datetime) -> dict[str, dict]:
    """The same per drop-off station: request -> that drop-off (and the task's pick-up)."""
    stops = TaskStop.objects.filter(
        action=StopAction.DROPOFF,
        task__site=period.site,
        task__requested_time__gte=period.start,
        task__requested_time__lt=period.end,
    ).order_by()
    stops = stops.annotate(ward=Coalesce(NullIf("waypoint__name", Value("")), "waypoint__code"))
    figures = {
        "deliveries": Count("pk"),
        "cancelled": Count("pk", filter=Q(task__status=TaskStatus.CANCELLED)),
        "due": Count(
            "pk", filter=Q(task__due_at__isnull=False) & ~Q(task__status=TaskStatus.CANCELLED)
        ),
        "on_time": Count("pk", filter=Q(done_at__lte=F("task__due_at"))),
    }
    durations = {
        "pickup": Seconds("task__picked_up_at", "task__requested_time"),
        "dropoff": Seconds("done_at", "task__requested_time"),
    }
    return _turnaround(stops, "ward", figures, durations)


def _turnaround(rows, key: str, figures: dict, durations: dict) -> dict[str, dict]:
    grouped = rows.values(key).annotate(**figures)
    result = {row[key]: {name: row[name] for name in figures} for row in grouped}
    for name, seconds in durations.items():
        for counts in result.values():
            counts[name] = {}
        for row in _histogram(rows, key, seconds, TURNAROUND_WIDTH):
            result[row[key]][name][str(int(row["bucket"]))] = row["n"]
    return result


def _histogram(rows, key: str, seconds, width: float):
    """(key, bucket, count) rows: how many durations round to each bucket (of `width` s)."""
    bucket = Round(seconds * Value(1 / width)) if width != 1 else Round(seconds)
    return (
        rows.annotate(bucket=bucket)
        .filter(bucket__isnull=False)
        .values(key, "bucket")
        .annotate(n=Count("pk"))
    )


def robot_utilisation(period: Period, *, now: datetime) -> dict[str, dict[str, float]]:
    """{robot id: {activity: seconds}} within [start, min(end, now)).

    Each activity row lasts until the robot's next one (LEAD); the row in force at the start is
    the robot's last one before it, found through the (robot, at) index.
    """
    table = RobotActivity._meta.db_table
    robots = Robot._meta.db_table
    stop = min(period.end, now)
    if stop <= period.start:
        return {}
    least, greatest = ("LEAST", "GREATEST") if connection.vendor == "postgresql" else ("MIN", "MAX")
    seconds = _seconds_sql("{l}(COALESCE(ends, %s), %s)", "{g}(starts, %s)")
    seconds = seconds.format(l=least, g=greatest)
    sql = f"""
        WITH picked AS (
            SELECT robot_id, activity, at, id FROM {table}
            WHERE robot_id IN (SELECT id FROM {robots} WHERE site_id = %s)
              AND at >= %s AND at < %s
            UNION ALL
            SELECT robot_id, activity, at, id FROM {table} WHERE id IN (
                SELECT (SELECT a.id FROM {table} a WHERE a.robot_id = r.id AND a.at < %s
                        ORDER BY a.at DESC, a.id DESC LIMIT 1)
                FROM {robots} r WHERE r.site_id = %s)
        ), spans AS (
            SELECT robot_id, activity, at AS starts,
                   LEAD(at) OVER (PARTITION BY robot_id ORDER BY at, id) AS ends
            FROM picked
        )
        SELECT robot_id, activity, SUM({seconds}) FROM spans GROUP BY robot_id, activity
    """
    adapt = connection.ops.adapt_datetimefield_value
    start, stop = adapt(period.start), adapt(stop)
    params = [period.site.pk, start, stop, start, period.site.pk, stop, stop, start]
    result: dict[str, dict[str, float]] = defaultdict(dict)
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        for robot_id, activity, total in cursor.fetchall():
            result[str(robot_id)][activity] = max(float(total or 0), 0.0)
    return dict(result)


def _seconds_sql(end: str, start: str) -> str:
    if connection.vendor == "postgresql":
        return f"EXTRACT(EPOCH FROM ({end} - {start}))"
    return f"((julianday({end}) - julianday({start})) * 86400.0)"


def resource_waits(period: Period, *, now: datetime) -> dict[str, dict]:
    """{"kind:code": {"requests": n, "wait": histogram of request -> grant}} per resource."""
    leases = Lease.objects.filter(
        resource__site=period.site,
        requested_at__gte=period.start,
        requested_at__lt=period.end,
        granted_at__isnull=False,
    ).order_by()
    leases = leases.annotate(resource_key=Concat("resource__kind", Value(":"), "resource__code"))
    result = {
        row["resource_key"]: {"requests": row["n"], "wait": {}}
        for row in leases.values("resource_key").annotate(n=Count("pk"))
    }
    wait = Seconds("granted_at", "requested_at")
    for row in _histogram(leases, "resource_key", wait, WAIT_WIDTH):
        result[row["resource_key"]]["wait"][str(int(row["bucket"]))] = row["n"]
    return result


def failures_by_cause(period: Period, *, now: datetime) -> dict[str, int]:
    """{"what:cause": n}: failed and cancelled deliveries by cause, alerts ("alert") by kind."""
    ended = (
        TaskTransition.objects.filter(
            new__in=[TaskStatus.FAILED, TaskStatus.CANCELLED],
            at__gte=period.start,
            at__lt=period.end,
            task__site=period.site,
        )
        .exclude(old=F("new"))
        .order_by()
        .values("new", "cause")
        .annotate(n=Count("pk"))
    )
    alerts = (
        Alert.objects.filter(
            site=period.site, raised_at__gte=period.start, raised_at__lt=period.end
        )
        .order_by()
        .values("kind")
        .annotate(n=Count("pk"))
    )
    result = {f"{row['new']}:{row['cause']}": row["n"] for row in ended}
    return result | {f"alert:{row['kind']}": row["n"] for row in alerts}


def stuck_by_robot(period: Period, *, now: datetime) -> dict[str, int]:
    """{robot code: n}: the times each robot got stuck (reported moving without progress past
    the site's stuck_timeout), one alert each (scheduling/services/stuck.py)."""
    raised = (
        Alert.objects.filter(
            site=period.site,
            kind=AlertKind.ROBOT_STUCK,
            raised_at__gte=period.start,
            raised_at__lt=period.end,
        )
        .order_by()
        .values("robot__code")
        .annotate(n=Count("pk"))
    )
    return {row["robot__code"] or "": row["n"] for row in raised}


FIGURES = {
    "per_day": deliveries_per_day,
    "per_hour": deliveries_per_hour,
    "by_priority": turnaround_by_priority,
    "by_ward": turnaround_by_ward,
    "utilisation": robot_utilisation,
    "resource_waits": resource_waits,
    "failures": failures_by_cause,
    "stuck": stuck_by_robot,
}
