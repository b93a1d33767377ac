"""A longer interval than the site's is told so that robots heartbeat spread over it
(core.overload.heartbeat_interval_spread): a robot keeps its phase, so a fleet that heard the
longer interval within one second would otherwise go on heartbeating within one second of it."""

import math
from collections import Counter
from datetime import UTC, datetime, timedelta

import pytest

from core.overload import heartbeat_interval_spread

NOW = datetime(2026, 11, 25, 5, 0, tzinfo=UTC)


def spread(robot_id, interval, now=NOW, base=1.0):
    return heartbeat_interval_spread(robot_id, interval, base=base, now=now)


def test_the_sites_own_interval_and_a_shorter_one_are_told_as_they_are():
    assert spread(1, 1.0) == 1.0
    assert spread(1, 3.0, base=3.0) == 3.0


@pytest.mark.parametrize("interval", [1.5, 2.5, 4.5, 10.0])
def test_each_robot_is_told_to_come_at_its_own_moment_of_the_interval(interval):
    for robot_id in (1, 2, 17, 90210):
        first = [spread(robot_id, interval, NOW + timedelta(seconds=s / 7)) for s in range(20)]
        comes = [s / 7 + told for s, told in enumerate(first)]
        # At least half the interval (and the site's) ahead, at most one interval more ...
        least = max(1.0, interval / 2)
        assert all(least <= told < least + interval for told in first)
        # ... and always at the same moment of the interval, whenever it is told.
        assert all(
            math.remainder(at - comes[0], interval) == pytest.approx(0, abs=2e-3) for at in comes
        )


def test_a_robot_that_keeps_to_its_moment_is_told_the_interval_itself():
    told = spread(1, 4.5)
    at = NOW + timedelta(seconds=told)

    assert spread(1, 4.5, at) == pytest.approx(4.5, abs=1e-3)
    # Arriving 40 ms late (its heartbeat queued), it is told 40 ms less: it stays on its moment.
    assert spread(1, 4.5, at + timedelta(seconds=0.04)) == pytest.approx(4.46, abs=1e-3)


@pytest.mark.parametrize("first_id", [1, 5000])
def test_a_fleet_slowed_within_one_second_comes_back_spread_over_the_interval(first_id):
    robots = range(first_id, first_id + 1000)
    # Spread over one second at 1 Hz, each hears 4.5 s at its next heartbeat.
    comes = [
        n / 1000 + spread(robot_id, 4.5, NOW + timedelta(seconds=n / 1000))
        for n, robot_id in enumerate(robots)
    ]
    per_twentieth = Counter(int((at % 4.5) / (4.5 / 20)) for at in comes)

    # Kept to their phases they would all come within one of the 4.5 seconds; spread, each
    # twentieth of the interval has its fiftieth, give or take two (robots' ids in a row take
    # slots as evenly apart as they can be: a crc32 of codes H0001 to H1000 gave 31 to 69).
    assert len(per_twentieth) == 20
    assert max(per_twentieth.values()) <= 52
    assert min(per_twentieth.values()) >= 48


def test_robots_with_ids_far_apart_are_spread_too():
    robots = range(7, 7 * 3000, 7)  # the robots of one site among others'
    slots = Counter(int(spread(robot_id, 4.5) % 4.5 / (4.5 / 20)) for robot_id in robots)

    assert max(slots.values()) < 1.1 * len(robots) / 20
