"""Deadlocks among leases (resources/deadlocks.py): the lease sweep finds robots waiting for
each other's resources and breaks the cycle by its rule (the most recently granted unused
grant yields and queues again, last) or, when every holder is inside, alerts operators.
Checked on cycles built by hand and on randomized sequences of requests by many robots over
the demo site's lift, door and corridor."""

from datetime import timedelta
from pathlib import Path

import pytest
from django.db import transaction
from django.utils import timezone
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from boards.models import BoardMessage
from resources.choices import LIVE_LEASE_STATES, LeaseEndCause, LeaseState
from resources.deadlocks import Hold, lease_deadlock_sweep, wait_cycles
from resources.models import Lease
from robots.models import Alert, Resource
from robots.sitefile import site_file_read, site_load
from tests import factories
from tests.factories import lease_acquire, lease_enter, lease_release

EULJI = Path(__file__).resolve().parents[2] / "sites" / "eulji.yaml"
ROBOTS = 8
RESOURCES = ("ELEV-A", "DOOR-2F-LAB", "CORR-6F")


def test_it_finds_each_cycle_of_waits_once():
    r1_door = Hold(1, robot=1, resource=10, state="granted")
    r2_lift = Hold(2, robot=2, resource=20, state="entered")
    r1_waits = Hold(3, robot=1, resource=20, state="queued")
    r2_waits = Hold(4, robot=2, resource=10, state="queued")
    r3_waits = Hold(5, robot=3, resource=10, state="queued")  # waits, holds nothing

    [cycle] = wait_cycles([r1_door, r2_lift, r1_waits, r2_waits, r3_waits])

    assert sorted(hold.lease for hold in cycle) == [1, 2]
    assert wait_cycles([r1_door, r2_lift, r1_waits, r3_waits]) == []
    three = [
        Hold(1, 1, 10, "granted"),
        Hold(2, 2, 20, "granted"),
        Hold(3, 3, 30, "entered"),
        Hold(4, 1, 20, "queued"),
        Hold(5, 2, 30, "queued"),
        Hold(6, 3, 10, "queued"),
    ]
    assert [sorted(h.lease for h in cycle) for cycle in wait_cycles(three)] == [[1, 2, 3]]


@pytest.fixture
def eulji(db):
    site = site_load(data=site_file_read(EULJI))
    robots = [factories.robot_create(site, f"D{n}") for n in range(ROBOTS)]
    resources = [Resource.objects.get(site=site, code=code) for code in RESOURCES]
    return site, robots, resources


def test_the_most_recently_granted_unused_grant_yields(eulji):
    _site, (r1, r2, *_), (lift, door, _corridor) = eulji
    now = timezone.now()
    held_door = lease_acquire(robot=r1, resource=door, request_id="q-1", now=now)
    held_lift = lease_acquire(robot=r2, resource=lift, request_id="q-2", to_floor="2F", now=now)
    lease_acquire(robot=r1, resource=lift, request_id="q-3", to_floor="2F", now=now)
    lease_acquire(robot=r2, resource=door, request_id="q-4", now=now)

    assert lease_deadlock_sweep(now=now + timedelta(seconds=1)) == 1

    held_lift.refresh_from_db()
    assert (held_lift.state, held_lift.end_cause) == (LeaseState.REVOKED, LeaseEndCause.DEADLOCK)
    again = Lease.objects.live().get(robot=r2, resource=lift)
    assert (again.state, again.request_id) == (LeaseState.QUEUED, "q-2")
    assert Lease.objects.live().get(robot=r1, resource=lift).state == LeaseState.GRANTED
    told = BoardMessage.objects.pending().get(robot=r2, key=again.board_key)
    assert (told.type, told.body["request"]) == ("resource_queued", "q-2")
    [alert] = Alert.objects.open().filter(kind="lease_deadlock")
    assert "D1 gave up its unused grant of ELEV-A" in alert.message
    held_door.refresh_from_db()
    assert held_door.state == LeaseState.GRANTED
    assert lease_deadlock_sweep(now=now + timedelta(seconds=2)) == 0


def test_robots_all_inside_are_left_to_operators_with_one_alert(eulji):
    _site, (r1, r2, *_), (lift, door, _corridor) = eulji
    lease_acquire(robot=r1, resource=door, request_id="q-1")
    lease_enter(robot=r1, resource=door)
    lease_acquire(robot=r2, resource=lift, request_id="q-2", to_floor="2F")
    lease_enter(robot=r2, resource=lift)
    lease_acquire(robot=r1, resource=lift, request_id="q-3", to_floor="2F")
    lease_acquire(robot=r2, resource=door, request_id="q-4")

    assert lease_deadlock_sweep() == 1
    assert lease_deadlock_sweep() == 1  # still there: the same alert, not a second

    [alert] = Alert.objects.open().filter(kind="lease_deadlock")
    assert "Every one of them is inside" in alert.message
    assert not Lease.objects.filter(end_cause=LeaseEndCause.DEADLOCK).exists()


STEPS = st.lists(
    st.tuples(
        st.integers(0, ROBOTS - 1),
        st.sampled_from(["acquire", "acquire", "enter", "release"]),
        st.integers(0, len(RESOURCES) - 1),
    ),
    min_size=1,
    max_size=40,
)


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(steps=STEPS)
# Cycles of two robots holding grants, of two inside, and of three, whatever Hypothesis draws.
@example(steps=[(0, "acquire", 1), (1, "acquire", 0), (0, "acquire", 0), (1, "acquire", 1)])
@example(
    steps=[
        (0, "acquire", 1),
        (0, "enter", 1),
        (1, "acquire", 0),
        (1, "enter", 0),
        (0, "acquire", 0),
        (1, "acquire", 1),
    ]
)
@example(
    steps=[
        (0, "acquire", 0),
        (1, "acquire", 1),
        (2, "acquire", 2),
        (2, "enter", 2),
        (0, "acquire", 1),
        (1, "acquire", 2),
        (2, "acquire", 0),
    ]
)
@example(
    # Breaking the cycle of D2 (door) and D0 (lift) hands the lift to D1, queued for it and
    # then for the door D2 holds: a new cycle, which the same sweep must break too.
    steps=[
        (2, "acquire", 1),
        (0, "acquire", 0),
        (0, "acquire", 1),
        (1, "acquire", 0),
        (1, "acquire", 1),
        (2, "acquire", 0),
    ]
)
def test_after_each_sweep_no_cycle_is_left_that_the_server_could_break(eulji, steps):
    _site, robots, resources = eulji
    with transaction.atomic():
        now = timezone.now()
        for n, (robot, op, resource) in enumerate(steps):
            now += timedelta(seconds=1)
            _step(robots[robot], op, resources[resource], n, now)
            lease_deadlock_sweep(now=now)
            _invariants_hold(resources)
        transaction.set_rollback(True)  # each example starts from the same site


def _step(robot, op, resource, n, now):
    mine = Lease.objects.live().filter(robot=robot, resource=resource).first()
    if op == "acquire":
        floor = "2F" if resource.is_elevator else None
        lease_acquire(robot=robot, resource=resource, request_id=f"q-{n}", to_floor=floor, now=now)
    elif op == "enter" and mine is not None and mine.state == LeaseState.GRANTED:
        lease_enter(robot=robot, resource=resource, now=now)
    elif op == "release" and mine is not None:
        lease_release(robot=robot, resource=resource, now=now)


def _invariants_hold(resources):
    live = list(Lease.objects.filter(state__in=LIVE_LEASE_STATES))
    holds = [Hold(x.pk, x.robot_id, x.resource_id, x.state) for x in live]
    for cycle in wait_cycles(holds):
        # Only robots inside their resources are left waiting for each other, for operators.
        assert all(hold.state == LeaseState.ENTERED for hold in cycle), cycle
        assert Alert.objects.open().filter(kind="lease_deadlock").exists()
    for resource in resources:
        holding = [x for x in live if x.resource_id == resource.pk and x.holds]
        assert len(holding) <= resource.capacity
    pairs = [(x.robot_id, x.resource_id) for x in live]
    assert len(pairs) == len(set(pairs)), "a robot has two live leases on one resource"
