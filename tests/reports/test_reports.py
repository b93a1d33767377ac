"""The reports: figures computed by the database agree with the same figures computed in
Python from the rows, whether read from the daily roll-ups or live; activities are clipped to
the period; and the page and its CSV exports are for operators, refuse bad input naming the
field, and carry the table's rows."""

import csv
import io
from collections import Counter
from datetime import date, datetime, timedelta
from zoneinfo import ZoneInfo

import pytest
from django.conf import settings
from django.test import Client
from django.utils import timezone

from reports.forms import LONGEST
from reports.models import DailyRollup
from reports.rollups import DAYS_PER_SWEEP, SETTLE, period_figures, rollup_sweep
from reports.seed import history_seed
from reports.selectors import Period
from reports.tables import BY_KEY, TABLES
from robots.models import Alert, RobotActivity
from scheduling.models import Task
from tests import factories

pytestmark = pytest.mark.django_db

ZONE = ZoneInfo(settings.TIME_ZONE)
END = datetime(2026, 11, 20, tzinfo=ZONE)
NOW = END + timedelta(days=1)


@pytest.fixture
def history(site):
    for code in ("R1", "R2"):
        factories.robot_create(site, code)
    return history_seed(site=site, deliveries=600, days=20, end=END, seed=3)


@pytest.fixture
def period(site, history):
    return Period(site=site, first=date(2026, 11, 1), last=date(2026, 11, 19))


def rows(key, period, now=NOW):
    return BY_KEY[key].compute(period, now=now)


def exact_percentile(values, fraction):
    """PERCENTILE_CONT: linear interpolation between the two nearest ranks."""
    ordered = sorted(values)
    position = (len(ordered) - 1) * fraction
    low = int(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


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

    days = rows("per_day", period)
    hours = rows("per_hour", period)

    assert len(days) == 19
    assert days[0]["day"] == "2026-11-01"
    assert {row["day"]: row["deliveries"] for row in days if row["deliveries"]} == dict(by_day)
    assert [row["deliveries"] for row in hours] == [by_hour.get(h, 0) for h in range(24)]
    assert 0 < sum(by_day.values()) < 600  # the period leaves out the first day seeded


def test_turnaround_by_priority_is_what_python_computes_from_the_rows(period):
    tasks = _tasks_in(period)
    by_priority = {row["priority"]: row for row in rows("by_priority", period)}

    assert set(by_priority) == {t.priority for t in tasks}
    for priority, row in by_priority.items():
        mine = [t for t in tasks if t.priority == priority]
        # The histograms count whole seconds: the percentile of the durations so rounded.
        dropoffs = [
            round((t.delivered_at - t.requested_time).total_seconds())
            for t in mine
            if t.delivered_at
        ]
        due = [t for t in mine if t.status != "cancelled" and t.due_at]
        on_time = [t for t in mine if t.delivered_at and t.delivered_at <= t.due_at]
        assert row["deliveries"] == len(mine)
        assert row["dropoff_p50_min"] == round(exact_percentile(dropoffs, 0.5) / 60, 1)
        assert row["dropoff_p90_min"] == round(exact_percentile(dropoffs, 0.9) / 60, 1)
        assert row["on_time_pct"] == round(100 * len(on_time) / len(due), 1)
    assert by_priority["urgent"]["dropoff_p50_min"] < by_priority["routine"]["dropoff_p50_min"]


def test_on_time_is_against_each_tasks_own_due_time(site, period):
    routine = [t for t in _tasks_in(period) if t.priority == "routine" and t.delivered_at]
    before = {row["priority"]: row for row in rows("by_priority", period)}["routine"]
    # A third get a due time a second before their drop-off: late, whatever their priority.
    for task in routine[::3]:
        Task.objects.filter(pk=task.pk).update(due_at=task.delivered_at - timedelta(seconds=1))
    # One has no due time (requested before deadlines existed): counted neither way.
    Task.objects.filter(pk=routine[1].pk).update(due_at=None)

    after = {row["priority"]: row for row in rows("by_priority", period)}["routine"]

    tasks = [t for t in _tasks_in(period) if t.priority == "routine"]
    due = [t for t in tasks if t.status != "cancelled" and t.due_at]
    on_time = [t for t in due if t.delivered_at and t.delivered_at <= t.due_at]
    assert len(due) == len([t for t in tasks if t.status != "cancelled"]) - 1
    assert after["on_time_pct"] == round(100 * len(on_time) / len(due), 1)
    assert after["on_time_pct"] < before["on_time_pct"] - 20


def test_the_sweep_stores_settled_days_and_the_reports_read_the_same_rows_from_them(period):
    live = {table.key: table.compute(period, now=NOW) for table in TABLES}

    stored = rollup_sweep(now=NOW)

    # Newest first, at most DAYS_PER_SWEEP a run: the period's days are among the first.
    days = set(DailyRollup.objects.filter(site=period.site).values_list("day", flat=True))
    assert stored == len(days) == DAYS_PER_SWEEP
    assert set(period.days) <= days
    assert {table.key: table.compute(period, now=NOW) for table in TABLES} == live
    runs = [rollup_sweep(now=NOW) for _ in range(LONGEST.days // DAYS_PER_SWEEP + 2)]
    assert runs[-1] == 0  # the window caught up: nothing new


def test_a_year_of_stored_days_is_read_in_one_query(period, django_assert_num_queries):
    rollup_sweep(now=NOW)
    with django_assert_num_queries(1):
        figures = period_figures(period, now=NOW)
    assert sum(figures["per_day"].values()) == len(_tasks_in(period))


def test_a_day_with_a_delivery_still_open_is_computed_live_until_it_settles(period):
    task = next(t for t in _tasks_in(period) if t.requested_time.astimezone(ZONE).day == 10)
    Task.objects.filter(pk=task.pk).update(status="picked_up", delivered_at=None, completed_at=None)
    rollup_sweep(now=NOW)
    open_day = date(2026, 11, 10)
    stored = DailyRollup.objects.filter(site=period.site)
    assert not stored.filter(day=open_day).exists()
    assert stored.filter(day=open_day - timedelta(days=1)).exists()

    def dropoffs():
        figures = period_figures(period, now=NOW)["by_priority"][task.priority]
        return sum(figures["dropoff"].values())

    before = dropoffs()
    delivered = task.requested_time + timedelta(minutes=30)
    Task.objects.filter(pk=task.pk).update(
        status="completed", delivered_at=delivered, completed_at=delivered
    )
    assert dropoffs() == before + 1  # the open day is read live: it already counts
    rollup_sweep(now=NOW)  # missing days newest first: the open day before older empty ones
    assert stored.filter(day=open_day).exists()
    assert dropoffs() == before + 1


def test_a_day_is_stored_only_once_it_has_ended_and_settled(site, history):
    today = Period(site=site, first=date(2026, 11, 19), last=date(2026, 11, 19))
    rollup_sweep(now=today.end + SETTLE - timedelta(seconds=1))
    assert not DailyRollup.objects.filter(site=site, day=today.first).exists()
    rollup_sweep(now=today.end + SETTLE)
    assert DailyRollup.objects.filter(site=site, day=today.first).exists()


def test_turnaround_by_ward_groups_by_drop_off_station(period):
    by_ward = rows("by_ward", period)
    stations = period.site.waypoints.filter(kind="station")
    names = {wp.name or wp.code for wp in stations}
    assert sum(row["deliveries"] for row in by_ward) == len(_tasks_in(period))
    assert {row["ward"] for row in by_ward} <= names
    assert len(by_ward) > 1


def test_utilisation_counts_each_activity_until_the_next_clipped_to_the_period(site):
    robot = factories.robot_create(site, "R9")
    day = Period(site=site, first=date(2026, 11, 2), last=date(2026, 11, 2))
    start = day.start
    for hours, activity in [(-1, "idle"), (1, "moving"), (3, "charging"), (30, "idle")]:
        RobotActivity.objects.create(
            robot=robot, at=start + timedelta(hours=hours), activity=activity
        )

    [row] = [
        r for r in rows("utilisation", day, now=start + timedelta(hours=5)) if r["robot"] == "R9"
    ]
    assert (row["idle_h"], row["moving_h"], row["charging_h"]) == (1.0, 2.0, 2.0)
    assert row["moving_pct"] == 40.0

    [whole] = [
        r for r in rows("utilisation", day, now=start + timedelta(days=9)) if r["robot"] == "R9"
    ]
    assert (whole["idle_h"], whole["moving_h"], whole["charging_h"]) == (1.0, 2.0, 21.0)


def test_resource_waits_and_failures(period):
    waits = rows("resource_waits", period)
    assert waits
    assert all(row["wait_p90_s"] >= row["wait_p50_s"] >= 0 for row in waits)
    failures = rows("failures", period)
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
        "stuck",
    ):
        assert f'id="chart-{key}"' in html
        assert f'id="data-{key}"' in html

    response = client.get("/reports/by_priority.csv", query)
    assert response["Content-Type"].startswith("text/csv")
    exported = list(csv.DictReader(io.StringIO(response.content.decode())))
    expected = rows("by_priority", period, now=timezone.now())
    assert [row["priority"] for row in exported] == [row["priority"] for row in expected]
    assert [float(row["dropoff_p50_min"]) for row in exported] == [
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
        ({"date_from": "9999-12-01", "date_to": "9999-12-31"}, "date_from"),
        ({"date_to": "9999-12-31"}, "date_to"),
        ({"date_from": "0001-01-01"}, "date_from"),
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


def test_an_unknown_site_is_404_naming_it(operator, site):
    client = Client()
    client.force_login(operator)
    response = client.get("/reports/per_day.csv", {"site": "nowhere"})
    assert response.status_code == 404
    assert "site" in response.json()["detail"]
    assert client.get("/reports/", {"site": "nowhere"}).status_code == 404


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


def test_it_counts_each_robot_getting_stuck_live_and_from_the_roll_ups(site):
    r1, r2 = (factories.robot_create(site, code) for code in ("R1", "R2"))
    raised = [
        ("robot_stuck", r1, datetime(2026, 11, 3, 9, tzinfo=ZONE)),
        ("robot_stuck", r1, datetime(2026, 11, 4, 23, 59, tzinfo=ZONE)),
        ("robot_stuck", r2, datetime(2026, 11, 4, 10, tzinfo=ZONE)),
        ("robot_stuck", r2, datetime(2026, 11, 6, 0, 0, tzinfo=ZONE)),  # the day after
        ("robot_error", r2, datetime(2026, 11, 4, 11, tzinfo=ZONE)),
    ]
    for n, (kind, robot, at) in enumerate(raised):
        Alert.objects.create(
            site=site, kind=kind, key=f"k{n}", message="", robot=robot, raised_at=at
        )
    period = Period(site=site, first=date(2026, 11, 3), last=date(2026, 11, 5))
    expected = [{"robot": "R1", "stuck": 2}, {"robot": "R2", "stuck": 1}]

    assert rows("stuck", period) == expected
    rollup_sweep(now=NOW)
    assert DailyRollup.objects.filter(site=site).exists()
    assert rows("stuck", period) == expected
