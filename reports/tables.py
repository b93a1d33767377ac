"""The reports page's tables: each with its columns, its chart and its CSV export, all from the
same rows, built from the period's summed figures (reports/rollups.py over
reports/selectors.py), so the chart, the table and the CSV never disagree."""

from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime

from django.utils.text import format_lazy
from django.utils.translation import gettext_lazy as _

from reports.histograms import percentile
from reports.rollups import period_figures
from reports.selectors import TURNAROUND_WIDTH, WAIT_WIDTH, Period
from robots.models import Robot

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
class Table:
    key: str  # also the name of the figure it shows (reports/selectors.py FIGURES)
    title: str  # lazily translated, as the headings
    columns: list[tuple[str, str]]  # (row key, heading)
    rows: Callable[[Period, dict], list[dict]]  # the period's summed figure -> rows
    chart: str  # Chart.js type
    label: str  # the row key the chart's x axis shows
    series: list[str] = field(default_factory=list)  # row keys drawn as datasets
    stacked: bool = False

    def compute(self, period: Period, *, now: datetime, figures: dict | None = None) -> list[dict]:
        """The rows; `figures` (reports/rollups.period_figures) when several tables share them."""
        if figures is None:
            figures = period_figures(period, now=now, names=[self.key])
        return self.rows(period, figures.get(self.key, {}))


def per_day_rows(period: Period, counts: dict) -> list[dict]:
    return [
        {"day": day.isoformat(), "deliveries": counts.get(day.isoformat(), 0)}
        for day in period.days
    ]


def per_hour_rows(period: Period, counts: dict) -> list[dict]:
    return [
        {"hour": f"{hour:02d}:00", "deliveries": counts.get(str(hour), 0)} for hour in range(24)
    ]


def turnaround_rows(key: str) -> Callable[[Period, dict], list[dict]]:
    """Per priority or ward: deliveries, cancelled, median and p90 of request -> pick-up and
    -> drop-off in minutes, and the share delivered by its due time (of those not cancelled
    that have one)."""

    def rows(period: Period, groups: dict) -> list[dict]:
        return [_turnaround_row(key, name, groups[name]) for name in sorted(groups)]

    return rows


def _turnaround_row(key: str, name: str, group: dict) -> dict:
    row = {key: name or "—", "deliveries": group["deliveries"], "cancelled": group["cancelled"]}
    for measure in ("pickup", "dropoff"):
        for label, fraction in (("p50", 0.5), ("p90", 0.9)):
            seconds = percentile(group.get(measure, {}), fraction, width=TURNAROUND_WIDTH)
            row[f"{measure}_{label}_min"] = None if seconds is None else round(seconds / 60, 1)
    due = group["due"]
    row["on_time_pct"] = round(100 * group["on_time"] / due, 1) if due else None
    return row


def utilisation_rows(period: Period, seconds: dict) -> list[dict]:
    """Per robot, hours in each activity group within the period (up to now), and shares."""
    rows = []
    for robot_id, code in Robot.objects.filter(site=period.site).values_list("pk", "code"):
        spent = dict.fromkeys(ACTIVITY_GROUPS, 0.0)
        for activity, duration in seconds.get(str(robot_id), {}).items():
            spent[GROUP_OF.get(activity, "idle")] += duration
        total = sum(spent.values())
        row = {"robot": code}
        for group, duration in spent.items():
            row[f"{group}_h"] = round(duration / 3600, 2)
            row[f"{group}_pct"] = round(100 * duration / total, 1) if total else 0.0
        rows.append(row)
    return rows


def resource_wait_rows(period: Period, resources: dict) -> list[dict]:
    rows = []
    for resource_key, figures in resources.items():
        kind, code = resource_key.split(":", 1)
        p50, p90 = (percentile(figures["wait"], f, width=WAIT_WIDTH) for f in (0.5, 0.9))
        rows.append(
            {
                "resource": code,
                "kind": kind,
                "requests": figures["requests"],
                "wait_p50_s": None if p50 is None else round(p50, 1),
                "wait_p90_s": None if p90 is None else round(p90, 1),
            }
        )
    return sorted(rows, key=lambda row: row["resource"])


def failure_rows(period: Period, counts: dict) -> list[dict]:
    rows = []
    for what_cause, count in counts.items():
        what, cause = what_cause.split(":", 1)
        rows.append({"what": what, "cause": cause, "count": count})
    return sorted(rows, key=lambda row: (row["what"], -row["count"], row["cause"]))


def stuck_rows(period: Period, counts: dict) -> list[dict]:
    return [{"robot": code or "?", "stuck": counts[code]} for code in sorted(counts)]


def _turnaround_columns(key: str, heading: str) -> list[tuple[str, str]]:
    return [
        (key, heading),
        ("deliveries", _("Deliveries")),
        ("cancelled", _("Cancelled")),
        ("pickup_p50_min", _("Request → pick-up, median (min)")),
        ("pickup_p90_min", _("Request → pick-up, p90 (min)")),
        ("dropoff_p50_min", _("Request → drop-off, median (min)")),
        ("dropoff_p90_min", _("Request → drop-off, p90 (min)")),
        ("on_time_pct", _("On time (%)")),
    ]


_UTILISATION_LABELS = {
    "moving": _("Moving"),
    "waiting_resource": _("Waiting for resources"),
    "loading_unloading": _("Loading and unloading"),
    "idle": _("Idle"),
    "charging": _("Charging"),
    "error": _("Error"),
    "offline": _("Offline or unreachable"),
}

TABLES = [
    Table(
        "per_day",
        _("Deliveries per day"),
        [("day", _("Day")), ("deliveries", _("Deliveries"))],
        per_day_rows,
        chart="bar",
        label="day",
        series=["deliveries"],
    ),
    Table(
        "per_hour",
        _("Deliveries by hour of day"),
        [("hour", _("Hour")), ("deliveries", _("Deliveries"))],
        per_hour_rows,
        chart="bar",
        label="hour",
        series=["deliveries"],
    ),
    Table(
        "by_priority",
        _("Turnaround by priority"),
        _turnaround_columns("priority", _("Priority")),
        turnaround_rows("priority"),
        chart="bar",
        label="priority",
        series=["pickup_p50_min", "pickup_p90_min", "dropoff_p50_min", "dropoff_p90_min"],
    ),
    Table(
        "by_ward",
        _("Turnaround by ward (drop-off station)"),
        _turnaround_columns("ward", _("Ward")),
        turnaround_rows("ward"),
        chart="bar",
        label="ward",
        series=["dropoff_p50_min", "dropoff_p90_min", "on_time_pct"],
    ),
    Table(
        "utilisation",
        _("Robot utilisation (hours)"),
        [("robot", _("Robot"))]
        + [
            (
                f"{group}{unit}",
                format_lazy("{} ({})", _UTILISATION_LABELS[group], unit[1:].replace("pct", "%")),
            )
            for group in ACTIVITY_GROUPS
            for unit in ("_h", "_pct")
        ],
        utilisation_rows,
        chart="bar",
        label="robot",
        series=[f"{group}_h" for group in ACTIVITY_GROUPS],
        stacked=True,
    ),
    Table(
        "resource_waits",
        _("Waiting for elevators, doors and corridors"),
        [
            ("resource", _("Resource")),
            ("kind", _("Kind")),
            ("requests", _("Requests")),
            ("wait_p50_s", _("Wait, median (s)")),
            ("wait_p90_s", _("Wait, p90 (s)")),
        ],
        resource_wait_rows,
        chart="bar",
        label="resource",
        series=["wait_p50_s", "wait_p90_s"],
    ),
    Table(
        "failures",
        _("Failures, cancellations and alerts by cause"),
        [("what", _("What")), ("cause", _("Cause")), ("count", _("Count"))],
        failure_rows,
        chart="bar",
        label="cause",
        series=["count"],
    ),
    Table(
        "stuck",
        "Stuck robots (moving without progress)",
        [("robot", "Robot"), ("stuck", "Times stuck")],
        stuck_rows,
        chart="bar",
        label="robot",
        series=["stuck"],
    ),
]
BY_KEY = {table.key: table for table in TABLES}


def series_label(table: Table, key: str) -> str:
    return dict(table.columns).get(key, key)
