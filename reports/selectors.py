"""The reports' figures for a site and a date range, each computed by the database in one
aggregate query over the stored histories (tasks and their stops and transitions, the robots'
activity, leases, alerts). Indexed on the site and time of each (bench/reports.py times them).

Each returns rows (dicts) with the same keys as its CSV export (reports/tables.py).
"""

from collections import defaultdict
from dataclasses import dataclass
from datetime import date, datetime, time, timedelta
from zoneinfo import ZoneInfo

from django.conf import settings
from django.db import connection
from django.db.models import Case, Count, DurationField, F, Q, Value, When
from django.db.models.functions import Coalesce, ExtractHour, NullIf, TruncDate

from reports.aggregates import Percentile, Seconds, database_percentiles, percentile
from reports.due import OTHERS, due_delta
from resources.models import Lease
from robots.models import Alert, Robot, RobotActivity, Site
from scheduling.choices import StopAction, TaskStatus
from scheduling.models import Task, TaskStop, TaskTransition

# Robot activities (RobotActivity.activity: a reported status, or a presence) in the groups
# the utilisation report shows, in its order.
ACTIVITY_GROUPS = {
    "moving": ["moving", "in_resource"],
    "waiting_resource": ["waiting_resource"],
    "loading_unloading": ["waiting_load", "waiting_unload"],
    "idle": ["idle", "paused", "unknown"],
    "charging": ["charging"],
    "error": ["error"],
    "offline": ["unreachable", "offline"],
}
GROUP_OF = {activity: group for group, members in ACTIVITY_GROUPS.items() for activity in members}


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


def _tasks(period: Period):
    return Task.objects.filter(
        site=period.site, requested_time__gte=period.start, requested_time__lt=period.end
    ).order_by()


def deliveries_per_day(period: Period) -> list[dict]:
    rows = (
        _tasks(period)
        .annotate(day=TruncDate("requested_time", tzinfo=period.zone))
        .values("day")
        .annotate(deliveries=Count("pk"))
    )
    counts = {row["day"]: row["deliveries"] for row in rows}
    days = (period.first + timedelta(days=n) for n in range((period.last - period.first).days + 1))
    return [{"day": day.isoformat(), "deliveries": counts.get(day, 0)} for day in days]


def deliveries_per_hour(period: Period) -> list[dict]:
    rows = (
        _tasks(period)
        .annotate(hour=ExtractHour("requested_time", tzinfo=period.zone))
        .values("hour")
        .annotate(deliveries=Count("pk"))
    )
    counts = {row["hour"]: row["deliveries"] for row in rows}
    return [{"hour": f"{hour:02d}:00", "deliveries": counts.get(hour, 0)} for hour in range(24)]


def _due(priority_field: str) -> Case:
    """Each row's due time after its requested time, by its priority (reports/due.py)."""
    named = [p for p in settings.DELIVERY_DUE_MINUTES if p != OTHERS]
    return Case(
        *(When(**{priority_field: p}, then=Value(due_delta(p))) for p in named),
        default=Value(due_delta(OTHERS)),
        output_field=DurationField(),
    )


def turnaround_by_priority(period: Period) -> list[dict]:
    """Per priority present: deliveries, request->pick-up and ->drop-off (median, p90, in
    minutes), and the share delivered by its due time (of those not cancelled)."""
    tasks = _tasks(period)
    due_at = F("requested_time") + _due("priority")
    figures = {
        "deliveries": Count("pk"),
        "cancelled": Count("pk", filter=Q(status=TaskStatus.CANCELLED)),
        "on_time": Count("pk", filter=Q(delivered_at__lte=due_at)),
    }
    durations = {
        "pickup": Seconds("picked_up_at", "requested_time"),
        "dropoff": Seconds("delivered_at", "requested_time"),
    }
    return _turnaround(tasks, "priority", figures, durations)


def turnaround_by_ward(period: Period) -> list[dict]:
    """The same per drop-off station: request -> that drop-off (and the task's pick-up)."""
    stops = TaskStop.objects.filter(
        action=StopAction.DROPOFF,
        task__site=period.site,
        task__requested_time__gte=period.start,
        task__requested_time__lt=period.end,
    ).order_by()
    stops = stops.annotate(ward=Coalesce(NullIf("waypoint__name", Value("")), "waypoint__code"))
    due_at = F("task__requested_time") + _due("task__priority")
    figures = {
        "deliveries": Count("pk"),
        "cancelled": Count("pk", filter=Q(task__status=TaskStatus.CANCELLED)),
        "on_time": Count("pk", filter=Q(done_at__lte=due_at)),
    }
    durations = {
        "pickup": Seconds("task__picked_up_at", "task__requested_time"),
        "dropoff": Seconds("done_at", "task__requested_time"),
    }
    return _turnaround(stops, "ward", figures, durations)


def _turnaround(rows, key: str, figures: dict, durations: dict) -> list[dict]:
    if database_percentiles():
        for name, seconds in durations.items():
            figures[f"{name}_p50"] = Percentile(seconds, 0.5)
            figures[f"{name}_p90"] = Percentile(seconds, 0.9)
        grouped = list(rows.values(key).annotate(**figures).order_by(key))
    else:
        grouped = _percentiles_in_python(rows, key, figures, durations)
    return [_turnaround_row(row, key) for row in grouped]


def _percentiles_in_python(rows, key, figures, durations) -> list[dict]:
    grouped = list(rows.values(key).annotate(**figures).order_by(key))
    values = defaultdict(lambda: defaultdict(list))
    for row in rows.annotate(**{f"_{n}": e for n, e in durations.items()}).values(
        key, *(f"_{n}" for n in durations)
    ):
        for name in durations:
            values[row[key]][name].append(row[f"_{name}"])
    for row in grouped:
        for name in durations:
            row[f"{name}_p50"] = percentile(values[row[key]][name], 0.5)
            row[f"{name}_p90"] = percentile(values[row[key]][name], 0.9)
    return grouped


def _turnaround_row(row: dict, key: str) -> dict:
    counted = row["deliveries"] - row["cancelled"]
    minutes = {
        name: None if row[name] is None else round(row[name] / 60, 1)
        for name in ("pickup_p50", "pickup_p90", "dropoff_p50", "dropoff_p90")
    }
    return {
        key: row[key] or "—",
        "deliveries": row["deliveries"],
        "cancelled": row["cancelled"],
        **{f"{name}_min": value for name, value in minutes.items()},
        "on_time_pct": round(100 * row["on_time"] / counted, 1) if counted else None,
    }


def robot_utilisation(period: Period, *, now: datetime) -> list[dict]:
    """Per robot, hours in each activity group within the period (up to now), and shares."""
    seconds = _activity_seconds(period, now=now)
    rows = []
    for robot_id, code in Robot.objects.filter(site=period.site).values_list("pk", "code"):
        spent = dict.fromkeys(ACTIVITY_GROUPS, 0.0)
        for activity, duration in seconds.get(robot_id, {}).items():
            spent[GROUP_OF.get(activity, "idle")] += duration
        total = sum(spent.values())
        row = {"robot": code}
        for group, duration in spent.items():
            row[f"{group}_h"] = round(duration / 3600, 2)
            row[f"{group}_pct"] = round(100 * duration / total, 1) if total else 0.0
        rows.append(row)
    return rows


def _activity_seconds(period: Period, *, now: datetime) -> dict[int, dict[str, float]]:
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
    result: dict[int, dict[str, float]] = defaultdict(dict)
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        for robot_id, activity, total in cursor.fetchall():
            result[robot_id][activity] = max(float(total or 0), 0.0)
    return result


def _seconds_sql(end: str, start: str) -> str:
    if connection.vendor == "postgresql":
        return f"EXTRACT(EPOCH FROM ({end} - {start}))"
    return f"((julianday({end}) - julianday({start})) * 86400.0)"


def resource_waits(period: Period) -> list[dict]:
    """Per elevator, door and corridor: requests, and the wait from request to grant."""
    leases = Lease.objects.filter(
        resource__site=period.site,
        requested_at__gte=period.start,
        requested_at__lt=period.end,
        granted_at__isnull=False,
    ).order_by()
    leases = leases.annotate(resource_code=F("resource__code"), kind=F("resource__kind"))
    wait = {"wait": Seconds("granted_at", "requested_at")}
    figures = {"requests": Count("pk")}
    if database_percentiles():
        figures |= {
            "wait_p50": Percentile(wait["wait"], 0.5),
            "wait_p90": Percentile(wait["wait"], 0.9),
        }
        rows = list(
            leases.values("resource_code", "kind").annotate(**figures).order_by("resource_code")
        )
    else:
        rows = _waits_in_python(leases, figures, wait["wait"])
    return [
        {
            "resource": row["resource_code"],
            "kind": row["kind"],
            "requests": row["requests"],
            "wait_p50_s": None if row["wait_p50"] is None else round(row["wait_p50"], 1),
            "wait_p90_s": None if row["wait_p90"] is None else round(row["wait_p90"], 1),
        }
        for row in rows
    ]


def _waits_in_python(leases, figures, wait) -> list[dict]:
    rows = list(
        leases.values("resource_code", "kind").annotate(**figures).order_by("resource_code")
    )
    values = defaultdict(list)
    for code, seconds in leases.annotate(_wait=wait).values_list("resource_code", "_wait"):
        values[code].append(seconds)
    for row in rows:
        row["wait_p50"] = percentile(values[row["resource_code"]], 0.5)
        row["wait_p90"] = percentile(values[row["resource_code"]], 0.9)
    return rows


def failures_by_cause(period: Period) -> list[dict]:
    """Failed and cancelled deliveries by cause, and operators' alerts by kind."""
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
    rows = [{"what": row["new"], "cause": row["cause"], "count": row["n"]} for row in ended]
    rows += [{"what": "alert", "cause": row["kind"], "count": row["n"]} for row in alerts]
    return sorted(rows, key=lambda row: (row["what"], -row["count"], row["cause"]))
