"""Presence (protocol v1): online within 3 heartbeat intervals, then unreachable, then offline.

Time is driven explicitly: each sweep is given its `now`.
"""

from datetime import timedelta

import pytest

from robots.hooks import presence_changed
from robots.models import PresenceChange, Robot
from robots.services import presence_sweep, presence_sweep_step


@pytest.fixture
def flips():
    seen = []

    def receiver(*, robot, old, new, at):
        seen.append((robot.code, old, new))

    with presence_changed.watched_by(receiver):
        yield seen


def seen_robot(robot_http, robot):
    robot_http.heartbeat(1)
    return Robot.objects.select_related("site").get(pk=robot.pk)


def test_a_robot_never_heard_from_is_offline(robot):
    assert robot.presence == "offline"
    assert robot.presence_at(robot.site.loaded_at) == "offline"


def test_it_stores_the_deadlines_at_each_heartbeat(robot_http, robot, flips):
    robot = seen_robot(robot_http, robot)

    assert robot.presence == "online"
    assert robot.unreachable_at - robot.last_seen_at == timedelta(seconds=3)
    assert robot.offline_at - robot.last_seen_at == timedelta(seconds=300)
    assert flips == [("R1", "offline", "online")]
    assert PresenceChange.objects.get().cause == "heartbeat"


def test_presence_is_a_function_of_the_stored_times_at_each_boundary(robot_http, robot):
    robot = seen_robot(robot_http, robot)
    seen = robot.last_seen_at
    tick = timedelta(microseconds=1)

    assert robot.presence_at(seen) == "online"
    assert robot.presence_at(seen + timedelta(seconds=3) - tick) == "online"
    assert robot.presence_at(seen + timedelta(seconds=3)) == "unreachable"
    assert robot.presence_at(seen + timedelta(seconds=300) - tick) == "unreachable"
    assert robot.presence_at(seen + timedelta(seconds=300)) == "offline"


def test_the_sweep_flips_only_robots_whose_deadline_passed(robot_http, robot, flips):
    robot = seen_robot(robot_http, robot)
    seen = robot.last_seen_at
    flips.clear()

    assert presence_sweep(now=seen + timedelta(seconds=2.999)) == 0
    assert presence_sweep(now=seen + timedelta(seconds=3)) == 1
    assert presence_sweep(now=seen + timedelta(seconds=299)) == 0
    assert presence_sweep(now=seen + timedelta(seconds=300)) == 1
    assert presence_sweep(now=seen + timedelta(seconds=900)) == 0

    assert flips == [("R1", "online", "unreachable"), ("R1", "unreachable", "offline")]
    assert Robot.objects.get(pk=robot.pk).presence == "offline"
    recorded = PresenceChange.objects.filter(cause="sweep").order_by("at")
    assert [(c.old, c.new, c.at - seen) for c in recorded] == [
        ("online", "unreachable", timedelta(seconds=3)),
        ("unreachable", "offline", timedelta(seconds=300)),
    ]


def test_a_late_sweep_goes_straight_to_offline(robot_http, robot, flips):
    robot = seen_robot(robot_http, robot)
    flips.clear()

    presence_sweep(now=robot.last_seen_at + timedelta(hours=1))

    assert flips == [("R1", "online", "offline")]


def test_a_heartbeat_brings_an_offline_robot_back_online(robot_http, robot, flips):
    robot = seen_robot(robot_http, robot)
    presence_sweep(now=robot.last_seen_at + timedelta(hours=1))
    flips.clear()

    robot_http.heartbeat(2)

    assert flips == [("R1", "offline", "online")]
    assert Robot.objects.get(pk=robot.pk).presence == "online"


def test_a_sweep_that_lost_the_race_to_a_heartbeat_flips_nothing(robot_http, robot, flips):
    stale_copy = seen_robot(robot_http, robot)
    robot_http.heartbeat(2)  # moves last_seen_at on after the sweep read the row
    flips.clear()

    later = stale_copy.last_seen_at + timedelta(hours=1)
    assert presence_sweep_step(robot=stale_copy, now=later) == 0
    assert flips == []
    assert Robot.objects.get(pk=robot.pk).presence == "online"


def test_a_stale_heartbeat_still_counts_as_a_sign_of_life(robot_http, robot):
    robot_http.heartbeat(10)
    first_seen = Robot.objects.get(pk=robot.pk).last_seen_at

    robot_http.heartbeat(4)

    assert Robot.objects.get(pk=robot.pk).last_seen_at > first_seen
