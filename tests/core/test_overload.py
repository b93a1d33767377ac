"""The heartbeat interval told under load (core/overload.py): the operator's ceiling, the wait
for a worker stamped by the proxy, and a fleet that settles where the server keeps up."""

import time
from datetime import timedelta

import pytest

from core.overload import (
    STEP_SECONDS,
    WAIT_SHARE,
    heartbeat_interval,
    heartbeat_interval_spread,
    request_waited,
)
from robots.services import presence_sweep
from tests import factories


def told(*, previous=1.0, waited=0.0, robots=10, capacity=1000, base=1.0, longest=10):
    return heartbeat_interval(
        base=base,
        previous=previous,
        waited=waited,
        robots=robots,
        capacity=capacity,
        longest=longest,
    )


def test_it_tells_the_sites_interval_to_a_fleet_the_server_keeps_up_with():
    assert told() == 1.0
    assert told(base=3.0, previous=0.0) == 3.0


def test_it_stretches_the_interval_to_keep_the_fleet_under_the_operators_ceiling():
    # 1,000 robots at 1 s against a ceiling of 500 a second: 1000 / (500 x 0.9) = 2.2 -> 2.5 s
    assert told(robots=1000, capacity=500) == 2.5


def test_a_ceiling_of_zero_turns_every_lengthening_off():
    assert told(robots=10_000, capacity=0, waited=30.0, previous=8.0) == 1.0


def test_a_long_wait_for_a_worker_adds_itself_to_the_interval():
    assert told(previous=2.0, waited=0.9) == 3.0  # 2.9 s, told in steps of half a second
    assert told(previous=1.0, waited=WAIT_SHARE * 1.0 + 0.01) == 1.5


def test_a_short_wait_shortens_the_interval_by_one_step_down_to_the_sites():
    assert told(previous=4.0, waited=0.1) == 4.0 - STEP_SECONDS
    assert told(previous=1.5, waited=0.0) == 1.0
    assert told(previous=1.0, waited=0.2) == 1.0


def test_the_interval_is_never_longer_than_the_longest_unless_the_sites_is():
    assert told(previous=9.5, waited=5.0, longest=10) == 10
    assert told(base=15.0, previous=15.0, waited=5.0, longest=10) == 15.0


@pytest.mark.parametrize(
    ("stamp", "waited"),
    [("t=1000.250", 0.75), ("1000.5", 0.5), (None, 0.0), ("", 0.0), ("t=soon", 0.0)],
)
def test_it_reads_the_wait_from_the_proxys_stamp(stamp, waited):
    assert request_waited(stamp, now=1001.0) == pytest.approx(waited)


def test_a_stamp_from_a_clock_ahead_or_far_behind_counts_as_no_wait():
    assert request_waited("t=1002.0", now=1001.0) == 0.0
    assert request_waited("t=0.0", now=1_000_000.0) == 0.0
    assert request_waited("t=1000.0", now=1061.0) == 0.0  # longer than nginx waits


def test_a_fleet_past_the_servers_capacity_settles_with_a_short_wait_and_keeps_it_busy():
    """A closed loop: N robots each wait for their answer, then the interval told. The server
    serves CAPACITY a second in arrival order; the ceiling is far above it, so only the wait
    slows the robots. Each robot is simulated heartbeat by heartbeat, no clock."""
    robots, capacity, service = 1000, 200.0, 1 / 200.0
    free_at, intervals = 0.0, [1.0] * robots
    arrivals = [n / robots for n in range(robots)]
    served, waits = 0, []
    while served < 40 * robots:
        n = min(range(robots), key=arrivals.__getitem__)
        start = max(arrivals[n], free_at)
        free_at = start + service
        waited = start - arrivals[n]
        intervals[n] = told(previous=intervals[n], waited=waited, robots=robots)
        arrivals[n] = free_at + intervals[n]
        served += 1
        if served > 30 * robots:
            waits.append((waited, intervals[n], free_at))
    cycle = max(at for *_, at in waits) - min(at for *_, at in waits)
    assert len(waits) / cycle > 0.95 * capacity  # the server stays busy
    # A robot's wait stays small beside the interval it obeys: it is never flipped for it.
    assert max(waited / interval for waited, interval, _ in waits) < 1.0
    assert max(interval for _, interval, _ in waits) <= 8.0  # 1,000 / 200 = 5 s at least


def test_a_robot_told_a_longer_interval_under_load_is_not_flipped_for_obeying(robot_http, robot):
    # As nginx stamps it, 2 s before the server reads it: the heartbeat waited 2 s for a worker.
    stamp = f"t={time.time() - 2.0:.3f}"
    body = factories.heartbeat_body(1)
    response = robot_http.post(body, headers={"X-Request-Start": stamp})
    answer = response.json()["heartbeat_interval"]
    robot.refresh_from_db()

    # 1 s + the 2 s waited and the moment the request took to arrive, in half-second steps
    assert robot.heartbeat_interval_told in (3.0, 3.5)
    told = robot.heartbeat_interval_told
    assert answer == heartbeat_interval_spread(robot.pk, told, base=1.0, now=robot.last_seen_at)
    # Three intervals told, and as long again as this one waited: the next may wait as long.
    assert robot.unreachable_at - robot.last_seen_at > timedelta(seconds=3 * answer + 2.0)
    presence_sweep(now=robot.last_seen_at + timedelta(seconds=3 * answer + 1.99))
    robot.refresh_from_db()
    assert robot.presence == "online"
