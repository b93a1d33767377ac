"""ETAs that come true: pick-up and drop-off ETAs with dwell, recomputed as the robot reports
progress, learning its pace from its own events, and counting the lease queue ahead of it."""

import itertools
from datetime import UTC, datetime, timedelta

import pytest
from django.db import transaction
from django.utils import timezone

from boards.serializers import HeartbeatSerializer
from boards.services import heartbeat_apply
from resources.leases import resource_wait_estimate
from resources.models import Resource
from robots.mapcache import site_map
from robots.services import robot_lock
from scheduling.services import task_allocate
from tests import factories
from tests.scheduling.conftest import request

T0 = datetime(2026, 11, 23, 9, 0, tzinfo=UTC)
TO_PHARMACY = 20.0  # 1F-DOCK-1 -> 1F-PHARM at the tiny site's 1 m/s
PHARMACY_TO_LAB = 82.5  # 20 m, the elevator one floor up (30 s + 2.5 s), 30 m
DWELL = 30.0  # the site's stop_dwell_seconds, until the robot has shown its own

_seqs = itertools.count(1)


def seconds(n: float) -> timedelta:
    return timedelta(seconds=n)


def beat(robot, *, now, at: str, events=()):
    """One heartbeat of `robot` at server time `now`, standing at waypoint `at`, through the
    real heartbeat service (validated, robot row locked, one transaction)."""
    with transaction.atomic():
        locked = robot_lock(robot.pk)
        body = factories.heartbeat_body(
            next(_seqs),
            boot_id="etas",
            state={"floor": at[:2], "waypoint": at, "plan_version": locked.plan_version},
            events=list(events),
        )
        serializer = HeartbeatSerializer(data=body, context={"site_map": site_map(locked.site)})
        serializer.is_valid(raise_exception=True)
        heartbeat_apply(robot=locked, heartbeat=serializer.validated_data, now=now)
    robot.refresh_from_db()


def event(type: str, task: str, stop: int, *, at: datetime) -> dict:
    """An event stamped by the robot's own clock."""
    iso = at.isoformat().replace("+00:00", "Z")
    return {"id": factories.event_id(), "type": type, "task": task, "stop": stop, "at": iso}


@pytest.fixture
def to_lab(r1, site):
    task = request(site, dropoffs=("2F-LAB",))
    task_allocate(task_id=task.pk, now=T0)
    task.refresh_from_db()
    return task


def test_a_plan_gives_each_task_a_pick_up_and_a_drop_off_eta_with_dwell(to_lab):
    assert to_lab.pickup_eta == T0 + seconds(TO_PHARMACY)
    assert to_lab.eta == T0 + seconds(TO_PHARMACY + DWELL + PHARMACY_TO_LAB + DWELL)


def test_a_task_behind_held_stops_is_estimated_after_them(r1, site, to_lab):
    second = request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
    task_allocate(task_id=second.pk, now=T0)
    second.refresh_from_db()

    at_the_lab = TO_PHARMACY + DWELL + PHARMACY_TO_LAB
    # Two stops at the lab, in either order (the same travel), a dwell each; then ward 3.
    assert second.pickup_eta in {T0 + seconds(at_the_lab), T0 + seconds(at_the_lab + DWELL)}
    assert second.eta == T0 + seconds(at_the_lab + DWELL + DWELL + 102.5 + DWELL)


def test_progress_recomputes_the_etas_and_learns_how_long_the_robot_stays(r1, to_lab):
    code = to_lab.code
    beat(r1, now=T0 + seconds(30), at="1F-PHARM", events=[event("arrived", code, 0, at=T0)])
    loaded_at = T0 + seconds(12)  # by the robot's clock: 12 s at the pharmacy

    beat(r1, now=T0 + seconds(40), at="1F-PHARM", events=[event("loaded", code, 0, at=loaded_at)])

    r1.refresh_from_db()
    to_lab.refresh_from_db()
    assert r1.pace_dwell == pytest.approx(12.0)
    assert to_lab.status == "picked_up"
    assert to_lab.pickup_eta is None  # picked up: nothing left to estimate
    assert to_lab.eta == T0 + seconds(40 + PHARMACY_TO_LAB + 12.0)


def test_a_delivery_reported_in_one_heartbeat_learns_each_stops_own_dwell(r1, to_lab):
    code, at_lab = to_lab.code, T0 + seconds(TO_PHARMACY + 12 + PHARMACY_TO_LAB)
    report = [  # back in Wi-Fi after the whole delivery: 12 s at the pharmacy, 20 s at the lab
        event("arrived", code, 0, at=T0),
        event("loaded", code, 0, at=T0 + seconds(12)),
        event("arrived", code, 1, at=at_lab),
        event("unloaded", code, 1, at=at_lab + seconds(20)),
    ]

    beat(r1, now=at_lab + seconds(30), at="2F-LAB", events=report)

    r1.refresh_from_db()
    assert r1.pace_dwell == pytest.approx(0.8 * 12.0 + 0.2 * 20.0)  # LEARNING_RATE 0.2


def test_each_tasks_dwell_is_learned_from_its_own_arrival(r1, site, to_lab):
    other = request(site, dropoffs=("3F-WARD",))
    task_allocate(task_id=other.pk, now=T0)
    other.refresh_from_db()
    lab, ward = to_lab.code, other.code
    report = [  # both picked up at the pharmacy: 12 s for the lab's, 20 s for the ward's
        event("arrived", ward, 0, at=T0),
        event("arrived", lab, 0, at=T0 + seconds(1)),
        event("loaded", lab, 0, at=T0 + seconds(13)),
        event("loaded", ward, 0, at=T0 + seconds(20)),
    ]

    beat(r1, now=T0 + seconds(30), at="1F-PHARM", events=report)

    r1.refresh_from_db()
    assert other.robot_id == r1.pk
    assert r1.pace_dwell == pytest.approx(0.8 * 12.0 + 0.2 * 20.0)


def test_a_robot_twenty_times_faster_than_the_map_is_predicted_so(r1, to_lab):
    code = to_lab.code
    beat(r1, now=T0 + seconds(2), at="1F-PHARM", events=[event("arrived", code, 0, at=T0)])
    loaded_at = T0 + seconds(2)
    beat(r1, now=T0 + seconds(3), at="1F-PHARM", events=[event("loaded", code, 0, at=loaded_at)])
    arrived_at = loaded_at + seconds(PHARMACY_TO_LAB / 20)

    beat(r1, now=T0 + seconds(8), at="2F-LAB", events=[event("arrived", code, 1, at=arrived_at)])

    r1.refresh_from_db()
    to_lab.refresh_from_db()
    assert r1.pace_travel == pytest.approx(1 / 20)
    assert to_lab.eta == T0 + seconds(8 + 2.0)  # at the lab: only its learned 2 s there left


def test_time_between_tasks_is_not_learned_as_travel(r1, site, to_lab):
    code = to_lab.code
    beat(r1, now=T0 + seconds(21), at="1F-PHARM", events=[event("arrived", code, 0, at=T0)])
    beat(r1, now=T0 + seconds(31), at="1F-PHARM", events=[event("loaded", code, 0, at=T0)])
    at_lab = T0 + seconds(PHARMACY_TO_LAB)  # by the map: pace 1
    beat(r1, now=T0 + seconds(120), at="2F-LAB", events=[event("arrived", code, 1, at=at_lab)])
    beat(r1, now=T0 + seconds(130), at="2F-LAB", events=[event("unloaded", code, 1, at=at_lab)])
    r1.refresh_from_db()
    assert r1.pace_travel == pytest.approx(1.0)
    # Ten minutes idle, then a task from the pharmacy: the robot drives there from the lab.
    given = T0 + seconds(730)
    second = request(site, dropoffs=("3F-WARD",))
    task_allocate(task_id=second.pk, now=given)
    there = at_lab + seconds(600 + PHARMACY_TO_LAB)  # by the robot's clock, as fast as before

    beat(
        r1,
        now=given + seconds(90),
        at="1F-PHARM",
        events=[event("arrived", second.code, 0, at=there)],
    )

    r1.refresh_from_db()
    assert r1.pace_travel == pytest.approx(1.0)  # not ten idle minutes over 82.5 s of travel


def test_the_eta_counts_the_lease_queue_on_the_robots_next_leg(r1, r2, site, to_lab):
    elevator = Resource.objects.get(site=site, code="ELEV")
    factories.lease_acquire(robot=r2, resource=elevator, request_id="q-r2", to_floor="3F", now=T0)
    factories.lease_enter(robot=r2, resource=elevator, now=T0)
    now = T0 + seconds(5)
    wait = resource_wait_estimate(resource=elevator, now=now)
    assert wait > 0  # R2 has been riding for 5 s of a typical 32.5 s

    beat(r1, now=now, at="1F-PHARM", events=[event("arrived", to_lab.code, 0, at=T0)])

    to_lab.refresh_from_db()
    # Loaded at the pharmacy, then the wait for the elevator, then on to the laboratory.
    assert to_lab.eta == now + seconds(DWELL + wait + PHARMACY_TO_LAB + DWELL)


def test_new_etas_go_to_the_pages_once_the_heartbeat_commits(
    r1, site, to_lab, monkeypatch, django_capture_on_commit_callbacks
):
    sent = []
    monkeypatch.setattr("ui.live.publish.group_send", lambda group, message: sent.append(message))
    before = to_lab.eta

    with django_capture_on_commit_callbacks() as callbacks:
        arrived = event("arrived", to_lab.code, 0, at=T0)
        beat(r1, now=T0 + seconds(30), at="1F-PHARM", events=[arrived])
        assert not [m for m in sent if m["kind"] == "etas"]  # not before the commit
    for callback in callbacks:
        callback()

    to_lab.refresh_from_db()
    assert to_lab.eta != before
    [message] = [m for m in sent if m["kind"] == "etas"]
    assert message["data"]["tasks"] == [
        {
            "code": to_lab.code,
            "eta": timezone.localtime(to_lab.eta).isoformat(),
            "eta_label": f"{timezone.localtime(to_lab.eta):%H:%M}",
            "pickup_eta": timezone.localtime(to_lab.pickup_eta).isoformat(),  # there now
            "lateness": "",
        }
    ]
    # The same progress again changes no ETA: nothing is sent.
    sent.clear()
    with django_capture_on_commit_callbacks(execute=True):
        beat(r1, now=T0 + seconds(30), at="1F-PHARM", events=[arrived])
    assert not [m for m in sent if m["kind"] == "etas"]
