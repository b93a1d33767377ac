"""A robot waiting at a drop-off that nobody unloads: operators alerted once, past the timeout;
past the site's longer unattended timeout it moves on by the site's policy."""

import copy
from datetime import timedelta
from unittest.mock import ANY

import pytest
from django.test import Client
from django.utils import timezone

from boards.models import RobotEvent
from robots.models import Alert, Site, SiteMembership
from robots.services import membership_badge_set
from robots.sitefile import SiteFileInvalid, site_load
from scheduling.models import CustodyEntry
from scheduling.selectors import schedule_for_site
from scheduling.services import (
    task_allocate,
    task_cancel,
    task_move_on,
    unattended_sweep,
    unload_timeout_sweep,
)
from scheduling.services.custody import custody_words
from tests import factories
from tests.scheduling.conftest import Beater, event, plans, request, robot_ready, route, status
from tests.scheduling.test_secure import LOCKING


def test_operators_are_alerted_once_when_nobody_unloads_past_the_sites_timeout(r1, site):
    task = request(site, dropoffs=("3F-WARD",), contents="Blood sample")
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0)])
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 1)], **at_ward)
    arrived = RobotEvent.objects.get(type="arrived").received_at
    timeout = timedelta(seconds=site.unload_timeout)

    assert unload_timeout_sweep(now=arrived + timeout - timedelta(seconds=1)) == 0
    assert unload_timeout_sweep(now=arrived + timeout) == 1
    assert unload_timeout_sweep(now=arrived + 2 * timeout) == 0

    alert = Alert.objects.get()
    assert (alert.kind, alert.robot, alert.task) == ("unload_timeout", r1, task.code)
    assert alert.message.startswith(
        f"R1 has waited 5 min at Ward 3 with Blood sample {task.code}: nobody has unloaded it"
    )
    assert "nobody has unloaded it" in task.history.last().note
    assert task.history.last().get_cause_display() == "Nobody unloaded it in time"


def test_a_wait_under_a_minute_is_told_in_seconds(r1, site):
    Site.objects.filter(pk=site.pk).update(unload_timeout=9)
    task = request(site, dropoffs=("3F-WARD",), contents="Blood sample")
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0)])
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 1)], **at_ward)
    arrived = RobotEvent.objects.get(type="arrived").received_at

    assert unload_timeout_sweep(now=arrived + timedelta(seconds=9)) == 1

    assert Alert.objects.get().message.startswith("R1 has waited 9 s at Ward 3")


def test_a_robot_unloaded_in_time_raises_nothing(r1, site):
    task = request(site, dropoffs=("3F-WARD",))
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0)])
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 1)], **at_ward)
    beater.beat(events=[event("unloaded", task.code, 1)], **at_ward)

    arrived = RobotEvent.objects.get(type="arrived").received_at
    assert unload_timeout_sweep(now=arrived + timedelta(hours=1)) == 0
    assert not Alert.objects.exists()


# --- Moving on after the site's longer unattended timeout ------------------------------------


def _waiting_at_the_ward(robot, site, **fields):
    """A secure delivery loaded into compartment A, its robot waiting at Ward 3 unloaded."""
    task = request(site, dropoffs=("3F-WARD",), contents="Morphine", secure=True, **fields)
    assert task_allocate(task_id=task.pk)
    beater = Beater(robot)
    beater.beat(events=[event("loaded", task.code, 0, compartment="A")])
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 1)], **at_ward)
    return task, beater, RobotEvent.objects.get(type="arrived").received_at


@pytest.fixture
def locking(site):
    return robot_ready(factories.robot_create(site, "R2", compartments=LOCKING))


def test_past_the_unattended_timeout_the_robot_brings_the_items_back_locked(
    locking, site, nurse, operator
):
    pharmacist = SiteMembership.objects.get(user=nurse, site=site)  # of the sending unit
    pharmacist.unit = site.waypoints.get(code="1F-PHARM")
    pharmacist.save(update_fields=["unit"])
    membership_badge_set(membership=pharmacist, badge="04:A2:19:C3:7F:5E:80")
    task, beater, arrived = _waiting_at_the_ward(locking, site, user=nurse)
    moves_on = timedelta(seconds=site.unattended_timeout)
    assert unload_timeout_sweep(now=arrived + moves_on - timedelta(seconds=1)) == 1  # the alert
    assert unattended_sweep(now=arrived + moves_on - timedelta(seconds=1)) == 0

    assert unattended_sweep(now=arrived + moves_on) == 1
    assert unattended_sweep(now=arrived + 2 * moves_on) == 0  # once

    task.refresh_from_db()
    assert (task.status, task.return_trip, task.unattended_at) == ("picked_up", True, ANY)
    [plan] = plans(beater.beat(floor="3F", waypoint="3F-WARD", status="waiting_unload"))[-1:]
    assert route(plan) == [(task.code, 2, "dropoff", "1F-PHARM")]  # back to the sender
    secure = plan["tasks"][task.code]["secure"]  # still opens only for its PIN...
    assert [badge["holder"] for badge in secure["badges"]] == ["kim"]  # ...or the sender's badges
    moved = CustodyEntry.objects.get(kind="moved_on")
    assert (moved.station, moved.compartment, moved.robot) == ("Ward 3", "A", locking)
    words = "Nobody unloaded it at Ward 3 in 30 min: R2 moved on, taking it to Pharmacy, locked in"
    assert task.history.last().note == f"{words} compartment A"
    open_alerts = list(Alert.objects.open().values_list("kind", "task"))
    assert open_alerts == [("unattended", task.code)]  # the unload alert closed by this one
    [row] = schedule_for_site(site=site, now=arrived + moves_on)
    assert row.notice == "Nobody unloaded it at the drop-off: on its way back, not delivered"

    back = event("unloaded", task.code, 2, compartment="A", opened_with="pin")
    beater.beat(events=[back], floor="1F", waypoint="1F-PHARM")

    assert status(task) == "failed"  # not delivered, nor cancelled: nobody took it
    beater.beat(events=[event("task_completed", task.code)], floor="1F", waypoint="1F-PHARM")
    assert task.history.last().note == f"{locking.code} finished its trip back with the items"
    assert task.history.filter(cause="unloading").count() == 2  # waited too long, moved on
    kinds = list(task.custody.order_by("pk").values_list("kind", "station"))  # time driven
    assert kinds == [
        ("loaded", "Pharmacy"),
        ("moved_on", "Ward 3"),
        ("unloaded", "Pharmacy"),
    ]
    assert custody_words(moved) == "Taken away from Ward 3 in compartment A: nobody unloaded it"
    client = Client()
    client.force_login(operator)
    # From the day it was sent to the day it was taken away (30 min later: past midnight, in
    # the site's time zone, when the test runs late in the evening there).
    sent, moved_day = timezone.localdate(task.created_at), timezone.localdate(moved.at)
    audit = client.get(f"/custody.csv?from={sent}&to={moved_day}").content.decode()
    assert "Taken away: nobody unloaded it" in audit


def test_the_sites_policy_may_name_a_return_station(locking, site):
    Site.objects.filter(pk=site.pk).update(unattended_return="2F-LAB")
    site.refresh_from_db()
    task, beater, arrived = _waiting_at_the_ward(locking, site)

    assert unattended_sweep(now=arrived + timedelta(seconds=site.unattended_timeout)) == 1

    [plan] = plans(beater.beat(floor="3F", waypoint="3F-WARD", status="waiting_unload"))[-1:]
    assert route(plan) == [(task.code, 2, "dropoff", "2F-LAB")]


def test_a_drop_off_unloaded_meanwhile_is_not_moved_on(locking, site):
    task, beater, arrived = _waiting_at_the_ward(locking, site)
    stop = task.stops.get(index=1)
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("unloaded", task.code, 1, compartment="A")], **at_ward)

    later = arrived + timedelta(hours=2)
    assert not task_move_on(robot_id=locking.pk, stop_id=stop.pk, waited=later - arrived, now=later)
    assert status(task) == "delivered"
    assert not CustodyEntry.objects.filter(kind="moved_on").exists()


def test_a_task_already_going_back_is_not_moved_on_again(locking, site, nurse):
    task = request(site, dropoffs=("3F-WARD",), secure=True, user=nurse)
    assert task_allocate(task_id=task.pk)
    beater = Beater(locking)
    beater.beat(events=[event("loaded", task.code, 0, compartment="A")])
    task_cancel(task=task, by=nurse)  # back to the pharmacy: its stop 2
    at_pharmacy = {"floor": "1F", "waypoint": "1F-PHARM", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 2)], **at_pharmacy)
    arrived = RobotEvent.objects.get(type="arrived").received_at

    assert unattended_sweep(now=arrived + timedelta(hours=2)) == 0

    assert list(task.stops.remaining().values_list("index", "waypoint__code")) == [(2, "1F-PHARM")]
    assert unload_timeout_sweep(now=arrived + timedelta(hours=2)) == 1  # operators alerted


def test_the_site_file_sets_the_policy_and_refuses_a_bad_one(db):
    data = copy.deepcopy(factories.TINY_SITE)
    data.update(unattended_timeout=900, unattended_return="2F-LAB")
    site = site_load(data=data)
    assert (site.unattended_timeout, site.unattended_return) == (900, "2F-LAB")

    data.update(unload_timeout=900, unattended_return="1F-HALL")
    with pytest.raises(SiteFileInvalid) as refused:
        site_load(data=data)
    assert refused.value.problems == [
        "unattended_timeout: must be longer than unload_timeout (900)",
        "unattended_return: 'pickup' or a station's code",
    ]
