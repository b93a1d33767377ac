"""The reports page's tables: each with its columns, its chart and its CSV export, all from the
same rows (reports/selectors.py), so the chart, the table and the CSV never disagree."""

from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime

from reports import selectors
from reports.selectors import ACTIVITY_GROUPS, Period


@dataclass(frozen=True)
class Table:
    key: str
    title: str
    columns: list[tuple[str, str]]  # (row key, heading)
    rows: Callable[..., list[dict]]
    chart: str  # Chart.js type
    label: str  # the row key the chart's x axis shows
    series: list[str] = field(default_factory=list)  # row keys drawn as datasets
    stacked: bool = False
    needs_now: bool = False

    def compute(self, period: Period, *, now: datetime) -> list[dict]:
        return self.rows(period, now=now) if self.needs_now else self.rows(period)


def _turnaround_columns(key: str, heading: str) -> list[tuple[str, str]]:
    return [
        (key, heading),
        ("deliveries", "Deliveries"),
        ("cancelled", "Cancelled"),
        ("pickup_p50_min", "Request → pick-up, median (min)"),
        ("pickup_p90_min", "Request → pick-up, p90 (min)"),
        ("dropoff_p50_min", "Request → drop-off, median (min)"),
        ("dropoff_p90_min", "Request → drop-off, p90 (min)"),
        ("on_time_pct", "On time (%)"),
    ]


_UTILISATION_LABELS = {
    "moving": "Moving",
    "waiting_resource": "Waiting for resources",
    "loading_unloading": "Loading and unloading",
    "idle": "Idle",
    "charging": "Charging",
    "error": "Error",
    "offline": "Offline or unreachable",
}

TABLES = [
    Table(
        "per_day",
        "Deliveries per day",
        [("day", "Day"), ("deliveries", "Deliveries")],
        selectors.deliveries_per_day,
        chart="bar",
        label="day",
        series=["deliveries"],
    ),
    Table(
        "per_hour",
        "Deliveries by hour of day",
        [("hour", "Hour"), ("deliveries", "Deliveries")],
        selectors.deliveries_per_hour,
        chart="bar",
        label="hour",
        series=["deliveries"],
    ),
    Table(
        "by_priority",
        "Turnaround by priority",
        _turnaround_columns("priority", "Priority"),
        selectors.turnaround_by_priority,
        chart="bar",
        label="priority",
        series=["pickup_p50_min", "pickup_p90_min", "dropoff_p50_min", "dropoff_p90_min"],
    ),
    Table(
        "by_ward",
        "Turnaround by ward (drop-off station)",
        _turnaround_columns("ward", "Ward"),
        selectors.turnaround_by_ward,
        chart="bar",
        label="ward",
        series=["dropoff_p50_min", "dropoff_p90_min", "on_time_pct"],
    ),
    Table(
        "utilisation",
        "Robot utilisation (hours)",
        [("robot", "Robot")]
        + [
            (f"{group}{unit}", f"{_UTILISATION_LABELS[group]} ({'h' if unit == '_h' else '%'})")
            for group in ACTIVITY_GROUPS
            for unit in ("_h", "_pct")
        ],
        selectors.robot_utilisation,
        chart="bar",
        label="robot",
        series=[f"{group}_h" for group in ACTIVITY_GROUPS],
        stacked=True,
        needs_now=True,
    ),
    Table(
        "resource_waits",
        "Waiting for elevators, doors and corridors",
        [
            ("resource", "Resource"),
            ("kind", "Kind"),
            ("requests", "Requests"),
            ("wait_p50_s", "Wait, median (s)"),
            ("wait_p90_s", "Wait, p90 (s)"),
        ],
        selectors.resource_waits,
        chart="bar",
        label="resource",
        series=["wait_p50_s", "wait_p90_s"],
    ),
    Table(
        "failures",
        "Failures, cancellations and alerts by cause",
        [("what", "What"), ("cause", "Cause"), ("count", "Count")],
        selectors.failures_by_cause,
        chart="bar",
        label="cause",
        series=["count"],
    ),
]
BY_KEY = {table.key: table for table in TABLES}


def series_label(table: Table, key: str) -> str:
    return dict(table.columns).get(key, key)
