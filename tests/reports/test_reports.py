"""The reports: figures computed by the database agree with the same figures computed in
Python from the rows, activities are clipped to the period, and the page and its CSV exports
are for operators, refuse bad input naming the field, and carry the table's rows."""

import csv
import io
from collections import Counter
from datetime import date, datetime, timedelta
from zoneinfo import ZoneInfo

import pytest
from django.conf import settings
from django.test import Client
from django.utils import timezone

from reports import selectors
from reports.aggregates import percentile
from reports.due import due_delta
from reports.seed import history_seed
from reports.selectors import Period
from robots.models import Alert, RobotActivity
from scheduling.models import Task
from tests import factories

pytestmark = pytest.mark.django_db

ZONE = ZoneInfo(settings.TIME_ZONE)
END = datetime(2026, 11, 20, tzinfo=ZONE)


@pytest.fixture
def history(site):
    for code in ("R1", "R2"):
        factories.robot_create(site, code)
    return history_seed(site=site, deliveries=600, days=20, end=END, seed=3)


@pytest.fixture
def period(site, history):
    return Period(site=site, first=date(2026, 11, 1), last=date(2026, 11, 19))


def _tasks_in(period):
    return [
        t
        for t in Task.objects.filter(site=period.site)
        if period.start <= t.requested_time < period.end
    ]


def test_deliveries_per_day_and_hour_count_every_request_in_the_period(period):
    tasks = _tasks_in(period)
    by_day = Counter(t.requested_time.astimezone(ZONE).date().isoformat() for t in tasks)
    by_hour = Counter(t.requested_time.astimezone(ZONE).hour for t in tasks)

    days = selectors.deliveries_per_day(period)
    hours = selectors.deliveries_per_hour(period)

    assert len(days) == 19
    assert days[0]["day"] == "2026-11-01"
    assert {row["day"]: row["deliveries"] for row in days if row["deliveries"]} == dict(by_day)
    assert [row["deliveries"] for row in hours] == [by_hour.get(h, 0) for h in range(24)]
    assert 0 < sum(by_day.values()) < 600  # the period leaves out the first day seeded


def test_turnaround_by_priority_is_what_python_computes_from_the_rows(period):
    tasks = _tasks_in(period)
    rows = {row["priority"]: row for row in selectors.turnaround_by_priority(period)}

    assert set(rows) == {t.priority for t in tasks}
    for priority, row in rows.items():
        mine = [t for t in tasks if t.priority == priority]
        dropoffs = [
            (t.delivered_at - t.requested_time).total_seconds() for t in mine if t.delivered_at
        ]
        counted = [t for t in mine if t.status != "cancelled"]
        on_time = [
            t
            for t in mine
            if t.delivered_at and t.delivered_at <= t.requested_time + due_delta(priority)
        ]
        assert row["deliveries"] == len(mine)
        assert row["dropoff_p50_min"] == round(percentile(dropoffs, 0.5) / 60, 1)
        assert row["dropoff_p90_min"] == round(percentile(dropoffs, 0.9) / 60, 1)
        assert row["on_time_pct"] == round(100 * len(on_time) / len(counted), 1)
    assert rows["urgent"]["dropoff_p50_min"] < rows["routine"]["dropoff_p50_min"]


def test_turnaround_by_ward_groups_by_drop_off_station(period):
    rows = selectors.turnaround_by_ward(period)
    stations = period.site.waypoints.filter(kind="station")
    names = {wp.name or wp.code for wp in stations}
    assert sum(row["deliveries"] for row in rows) == len(_tasks_in(period))
    assert {row["ward"] for row in rows} <= names
    assert len(rows) > 1


def test_utilisation_counts_each_activity_until_the_next_clipped_to_the_period(site):
    robot = factories.robot_create(site, "R9")
    day = Period(site=site, first=date(2026, 11, 2), last=date(2026, 11, 2))
    start = day.start
    for hours, activity in [(-1, "idle"), (1, "moving"), (3, "charging"), (30, "idle")]:
        RobotActivity.objects.create(
            robot=robot, at=start + timedelta(hours=hours), activity=activity
        )

    [row] = [
        r
        for r in selectors.robot_utilisation(day, now=start + timedelta(hours=5))
        if r["robot"] == "R9"
    ]
    assert (row["idle_h"], row["moving_h"], row["charging_h"]) == (1.0, 2.0, 2.0)
    assert row["moving_pct"] == 40.0

    [whole] = [
        r
        for r in selectors.robot_utilisation(day, now=start + timedelta(days=9))
        if r["robot"] == "R9"
    ]
    assert (whole["idle_h"], whole["moving_h"], whole["charging_h"]) == (1.0, 2.0, 21.0)


def test_resource_waits_and_failures(period):
    waits = selectors.resource_waits(period)
    assert waits
    assert all(row["wait_p90_s"] >= row["wait_p50_s"] >= 0 for row in waits)
    failures = selectors.failures_by_cause(period)
    cancelled = sum(row["count"] for row in failures if row["what"] == "cancelled")
    # cancelled within the period, of tasks requested in it or just before
    assert cancelled == sum(
        1
        for t in Task.objects.filter(site=period.site, status="cancelled")
        if period.start <= t.cancelled_at < period.end
    )
    alerts = sum(row["count"] for row in failures if row["what"] == "alert")
    raised = Alert.objects.filter(site=period.site, raised_at__range=(period.start, period.end))
    assert alerts == raised.count()
    failed = sum(row["count"] for row in failures if row["what"] == "failed")
    ended = Task.objects.filter(site=period.site, status="failed")
    assert failed == ended.filter(failed_at__gte=period.start, failed_at__lt=period.end).count()


def test_the_page_shows_every_table_and_its_csv_has_the_same_rows(operator, site, period):
    client = Client()
    client.force_login(operator)
    query = {"site": site.code, "date_from": "2026-11-01", "date_to": "2026-11-19"}

    page = client.get("/reports/", query)
    assert page.status_code == 200
    html = page.content.decode()
    for key in (
        "per_day",
        "per_hour",
        "by_priority",
        "by_ward",
        "utilisation",
        "resource_waits",
        "failures",
    ):
        assert f'id="chart-{key}"' in html
        assert f'id="data-{key}"' in html

    response = client.get("/reports/by_priority.csv", query)
    assert response["Content-Type"].startswith("text/csv")
    rows = list(csv.DictReader(io.StringIO(response.content.decode())))
    expected = selectors.turnaround_by_priority(period)
    assert [row["priority"] for row in rows] == [row["priority"] for row in expected]
    assert [float(row["dropoff_p50_min"]) for row in rows] == [
        row["dropoff_p50_min"] for row in expected
    ]


def test_reports_are_for_operators(nurse, site):
    client = Client()
    client.force_login(nurse)
    assert client.get("/reports/").status_code == 403
    assert client.get("/reports/per_day.csv").status_code == 403


@pytest.mark.parametrize(
    ("query", "field"),
    [
        ({"date_from": "2026-11-10", "date_to": "2026-11-01"}, "date_from"),
        ({"date_from": "yesterday"}, "date_from"),
        ({"date_to": "2026-13-01"}, "date_to"),
        ({"date_from": "2024-01-01", "date_to": "2026-01-01"}, "date_from"),
        ({"site": "nowhere"}, "site"),
    ],
)
def test_bad_input_is_refused_naming_the_field(operator, site, query, field):
    client = Client()
    client.force_login(operator)
    response = client.get("/reports/per_day.csv", query)
    assert response.status_code == 400
    assert response.json()["error"] == "invalid"
    assert field in response.json()["detail"]
    page = client.get("/reports/", query)
    assert page.status_code == 400


def test_an_unknown_table_is_404_in_the_error_shape(operator, site):
    client = Client()
    client.force_login(operator)
    response = client.get("/reports/nothing.csv")
    assert response.status_code == 404
    assert "table" in response.json()["detail"]


def test_the_default_period_is_the_last_30_days(operator, site):
    client = Client()
    client.force_login(operator)
    today = timezone.localdate()
    response = client.get("/reports/per_day.csv")
    days = [row["day"] for row in csv.DictReader(io.StringIO(response.content.decode()))]
    assert days[0] == (today - timedelta(days=29)).isoformat()
    assert days[-1] == today.isoformat()
