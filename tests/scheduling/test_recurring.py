"""Periodic requests create their task instances on time, once each (time driven explicitly)."""

import threading
from datetime import datetime, timedelta
from zoneinfo import ZoneInfo

import pytest
from django.conf import settings
from django.db import connection

from scheduling.models import RecurringRequest, Task
from scheduling.recurrence import next_occurrence, occurrences
from scheduling.services import due_sweep, recurring_sweep
from tests.scheduling.conftest import request

LOCAL = ZoneInfo(settings.TIME_ZONE)
EVERY_TWO_HOURS = {"every_minutes": 120, "from": "08:00", "until": "20:00"}


def local(day: int, hour: int, minute: int = 0) -> datetime:
    return datetime(2026, 11, day, hour, minute, tzinfo=LOCAL)


def test_daily_times_occur_every_day_in_local_time():
    found = list(occurrences({"times": ["14:00", "08:00"]}, local(22, 9), local(24, 8)))

    assert found == [local(22, 14), local(23, 8), local(23, 14), local(24, 8)]


def test_every_n_minutes_occurs_within_the_window_both_ends_included():
    found = list(occurrences(EVERY_TWO_HOURS, local(22, 0), local(22, 23, 59)))

    assert [at.hour for at in found] == [8, 10, 12, 14, 16, 18, 20]
    assert next_occurrence(EVERY_TWO_HOURS, local(22, 20, 1)) == local(23, 8)


def test_a_periodic_request_creates_its_first_instance(site, staff):
    first = request(site, user=staff, repeat={"times": ["08:00"]}, now=local(22, 9))

    recurring = RecurringRequest.objects.get()
    assert (first.recurring, first.requested_time, first.status) == (
        recurring,
        local(23, 8),
        "scheduled",
    )
    assert first.scheduled_for == local(23, 8)
    assert first.history.get().cause == "schedule"
    assert recurring.requester == staff


def test_the_sweep_creates_each_instance_once_and_a_little_ahead(site):
    request(site, repeat=EVERY_TWO_HOURS, now=local(22, 7))  # first instance: 08:00

    assert recurring_sweep(now=local(22, 9, 49)) == 0  # 10:00 is more than 10 minutes away
    assert recurring_sweep(now=local(22, 9, 50)) == 1
    assert recurring_sweep(now=local(22, 9, 55)) == 0
    assert recurring_sweep(now=local(22, 9, 55)) == 0

    times = Task.objects.order_by("requested_time").values_list("requested_time", flat=True)
    assert list(times) == [local(22, 8), local(22, 10)]


def test_an_instance_falls_due_at_its_time(site):
    request(site, repeat={"times": ["10:00"]}, now=local(22, 9))
    instance = Task.objects.get()

    due_sweep(now=local(22, 10) - timedelta(milliseconds=1))
    instance.refresh_from_db()
    assert instance.status == "scheduled"

    due_sweep(now=local(22, 10))
    instance.refresh_from_db()
    assert instance.status == "due"  # no robot here to take it
    assert instance.history.last().cause == "sweep"


def test_occurrences_missed_while_the_sweep_was_down_are_created_late_and_marked(site):
    request(site, repeat=EVERY_TWO_HOURS, now=local(22, 7))  # 08:00

    # The sweep did not run from 07:00 to 14:05 (Celery beat down), then restarts.
    assert recurring_sweep(now=local(22, 14, 5)) == 3  # 10:00 and 12:00 late, and 14:00

    times = Task.objects.values_list("requested_time", flat=True)
    assert set(times) == {local(22, 8), local(22, 10), local(22, 12), local(22, 14)}
    for hour, late in ((10, "245 min ago"), (12, "125 min ago")):
        created = Task.objects.get(requested_time=local(22, hour)).history.get()
        assert created.cause == "schedule"
        assert created.note == f"created late: due at {hour}:00, {late}"
    assert (
        Task.objects.get(requested_time=local(22, 14)).history.get().note.startswith("created late")
    )
    assert recurring_sweep(now=local(22, 14, 6)) == 0  # once each


def test_occurrences_more_than_a_day_old_are_not_created(site):
    request(site, repeat={"times": ["08:00"]}, now=local(20, 7))  # 20th 08:00

    assert recurring_sweep(now=local(23, 9)) == 1  # only the 23rd's, an hour late

    times = Task.objects.values_list("requested_time", flat=True)
    assert set(times) == {local(20, 8), local(23, 8)}


def test_an_inactive_periodic_request_creates_nothing(site):
    request(site, repeat=EVERY_TWO_HOURS, now=local(22, 7))
    RecurringRequest.objects.update(active=False)

    assert recurring_sweep(now=local(22, 9, 55)) == 0


@pytest.mark.django_db(transaction=True)
def test_concurrent_sweeps_create_an_instance_once(site):
    request(site, repeat=EVERY_TWO_HOURS, now=local(22, 7))
    barrier, created = threading.Barrier(2), []

    def sweep():
        try:
            barrier.wait(timeout=10)
            created.append(recurring_sweep(now=local(22, 9, 55)))
        finally:
            connection.close()

    threads = [threading.Thread(target=sweep) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30)

    assert sorted(created) == [0, 1]
    assert Task.objects.filter(requested_time=local(22, 10)).count() == 1
