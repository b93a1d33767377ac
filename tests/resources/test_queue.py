"""What the scheduler reads: a resource's queue and how long a new request would wait."""

from datetime import timedelta

import pytest
from django.utils import timezone

from resources.leases import resource_queue, resource_wait_estimate
from tests import factories
from tests.factories import lease_acquire, lease_enter, lease_release
from tests.resources.conftest import resource

SECOND = timedelta(seconds=1)


@pytest.fixture
def t0():
    return timezone.now()


@pytest.fixture
def robots(site):
    return [factories.robot_create(site, f"R{n}") for n in range(1, 5)]


def ask(robot, code, at, to_floor=None):
    return lease_acquire(
        robot=robot,
        resource=resource(code),
        request_id=f"q-{robot.code}-{at.timestamp()}",
        to_floor=to_floor or ("2F" if code == "ELEV" else None),
        now=at,
    )


def test_it_lists_holders_first_then_the_queue_in_arrival_order(robots, t0):
    r1, r2, r3, r4 = robots
    for n, robot in enumerate([r2, r1, r4, r3]):
        ask(robot, "CORR-3F", t0 + n * SECOND)
    lease_enter(robot=r1, resource=resource("CORR-3F"), now=t0)

    queue = resource_queue(resource=resource("CORR-3F"))

    assert [(lease.robot.code, lease.state) for lease in queue] == [
        ("R2", "granted"),
        ("R1", "entered"),
        ("R4", "queued"),
        ("R3", "queued"),
    ]


def test_it_estimates_no_wait_at_a_free_resource(robots, t0):
    ask(robots[0], "CORR-3F", t0)

    assert resource_wait_estimate(resource=resource("CORR-3F"), now=t0) == 0.0


def test_it_estimates_a_ride_from_the_map_without_history(robots, t0):
    ask(robots[0], "ELEV", t0)
    ride = 30 + 2.5  # overhead_seconds + seconds_per_floor of the tiny site's elevator

    assert resource_wait_estimate(resource=resource("ELEV"), now=t0) == ride
    assert resource_wait_estimate(resource=resource("ELEV"), now=t0 + 10 * SECOND) == ride - 10
    ask(robots[1], "ELEV", t0)
    ask(robots[2], "ELEV", t0)
    assert resource_wait_estimate(resource=resource("ELEV"), now=t0) == 3 * ride


def test_it_learns_the_typical_hold_from_completed_leases(robots, t0):
    door = resource("DOOR-2F")
    for n, robot in enumerate(robots[:2]):
        ask(robot, "DOOR-2F", t0 + n * 100 * SECOND)
        lease_release(robot=robot, resource=door, now=t0 + (n * 100 + 4 + 2 * n) * SECOND)
    ask(robots[2], "DOOR-2F", t0 + 300 * SECOND)
    ask(robots[3], "DOOR-2F", t0 + 300 * SECOND)

    # holds of 4 s and 6 s: 5 s typical; one holder just granted, one waiting ahead
    assert resource_wait_estimate(resource=door, now=t0 + 300 * SECOND) == 10.0


def test_it_serves_a_corridor_queue_two_at_a_time(robots, t0):
    corridor = resource("CORR-3F")
    for robot in robots:
        ask(robot, "CORR-3F", t0)

    # two holders just granted (15 s each by default), two waiting: they enter at 15 s and
    # leave at 30 s, when a fifth robot would get in
    assert resource_wait_estimate(resource=corridor, now=t0) == 30.0


def test_a_grant_is_never_recorded_before_the_end_of_the_hold_it_follows(robots, t0):
    """A heartbeat takes its time before it waits for the resource's lock: here R2's asked at
    t0 + 0.5 s but was applied after R1's release, recorded at t0 + 1 s."""
    r1, r2 = robots[:2]
    ask(r1, "ELEV", t0)
    lease_enter(robot=r1, resource=resource("ELEV"), now=t0)
    ended = lease_release(robot=r1, resource=resource("ELEV"), now=t0 + SECOND)

    granted = ask(r2, "ELEV", t0 + SECOND / 2)

    assert granted.state == "granted"
    assert granted.requested_at == t0 + SECOND / 2
    assert granted.granted_at == ended.ended_at == t0 + SECOND
    grant_timeout = timedelta(seconds=granted.resource.site.grant_timeout)
    assert granted.expires_at == t0 + SECOND + grant_timeout
