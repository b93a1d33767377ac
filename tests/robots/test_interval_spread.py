"""A longer interval than the site's is told so that robots heartbeat spread over it
(robots.cadence.heartbeat_interval_spread): a robot keeps its phase, so a fleet that heard the
longer interval within one second would otherwise go on heartbeating within one second of it."""

import math
from collections import Counter
from datetime import UTC, datetime, timedelta

import pytest

from robots.cadence import heartbeat_interval_spread

NOW = datetime(2026, 11, 25, 5, 0, tzinfo=UTC)


def spread(code, interval, now=NOW, base=1.0):
    return heartbeat_interval_spread(code, interval, base=base, now=now)


def test_the_sites_own_interval_and_a_shorter_one_are_told_as_they_are():
    assert spread("R1", 1.0) == 1.0
    assert spread("R1", 3.0, base=3.0) == 3.0


@pytest.mark.parametrize("interval", [1.5, 2.5, 4.5, 10.0])
def test_each_robot_is_told_to_come_at_its_own_moment_of_the_interval(interval):
    for code in ("R1", "R2", "AMR-017", "tug-3"):
        first = [spread(code, interval, NOW + timedelta(seconds=s / 7)) for s in range(20)]
        comes = [s / 7 + told for s, told in enumerate(first)]
        # At least half the interval (and the site's) ahead, at most one interval more ...
        least = max(1.0, interval / 2)
        assert all(least <= told < least + interval for told in first)
        # ... and always at the same moment of the interval, whenever it is told.
        assert all(
            math.remainder(at - comes[0], interval) == pytest.approx(0, abs=2e-3) for at in comes
        )


def test_a_robot_that_keeps_to_its_moment_is_told_the_interval_itself():
    told = spread("R1", 4.5)
    at = NOW + timedelta(seconds=told)

    assert spread("R1", 4.5, at) == pytest.approx(4.5, abs=1e-3)
    # Arriving 40 ms late (its heartbeat queued), it is told 40 ms less: it stays on its moment.
    assert spread("R1", 4.5, at + timedelta(seconds=0.04)) == pytest.approx(4.46, abs=1e-3)


def test_a_fleet_slowed_within_one_second_comes_back_spread_over_the_interval():
    robots = [f"R{n}" for n in range(1000)]
    # Spread over one second at 1 Hz, each hears 4.5 s at its next heartbeat.
    comes = [
        n / 1000 + spread(code, 4.5, NOW + timedelta(seconds=n / 1000))
        for n, code in enumerate(robots)
    ]
    per_half_second = Counter(int((at % 4.5) / 0.5) for at in comes)

    # Kept to their phases they would all come within one of the nine half-seconds; spread,
    # each half-second has about its ninth (111), none more than 1.3 times that.
    assert len(per_half_second) == 9
    assert max(per_half_second.values()) < 1.3 * 1000 / 9
