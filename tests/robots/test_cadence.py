"""The heartbeat interval told to robots follows the load (robots/cadence.py), and presence
deadlines follow the interval each robot was told, so a robot that obeys is never flipped."""

from datetime import timedelta

import pytest

from robots.cadence import cadence_forget
from robots.models import Robot
from robots.services import presence_sweep
from tests import factories


@pytest.fixture(autouse=True)
def fresh_count():
    cadence_forget()
    yield
    cadence_forget()


def robots_heartbeating(site, count):
    """`count` robots besides R1 that the server believes are heartbeating."""
    for n in range(count):
        robot = factories.robot_create(site, f"X{n + 1}")
        Robot.objects.filter(pk=robot.pk).update(presence="online")


def test_under_capacity_robots_are_told_the_sites_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 100
    robots_heartbeating(robot.site, 10)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 1.0


def test_over_capacity_every_robot_is_told_a_longer_interval_in_steps(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10  # aimed at 9/s: 21 robots need 2.33 s, told 2.5 s
    robots_heartbeating(robot.site, 20)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 2.5


def test_the_interval_falls_back_when_robots_go_offline(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10
    robots_heartbeating(robot.site, 20)
    assert robot_http.heartbeat(1)["heartbeat_interval"] == 2.5

    Robot.objects.exclude(pk=robot.pk).update(presence="offline")
    cadence_forget()  # the next count, as COUNT_SECONDS later

    assert robot_http.heartbeat(2)["heartbeat_interval"] == 1.0


def test_the_interval_is_capped(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1
    settings.HEARTBEAT_INTERVAL_MAX = 4
    robots_heartbeating(robot.site, 20)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 4.0


def test_a_robot_that_obeys_a_longer_interval_is_not_flipped(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10
    robots_heartbeating(robot.site, 20)
    told = robot_http.heartbeat(1)["heartbeat_interval"]
    robot.refresh_from_db()
    seen = robot.last_seen_at

    assert robot.unreachable_at - seen == timedelta(seconds=3 * told)
    # Two told intervals later (5 s, past the site's 3 s), the sweep leaves it online ...
    presence_sweep(now=seen + timedelta(seconds=2 * told))
    robot.refresh_from_db()
    assert robot.presence == "online"
    # ... and flips it only once 3 told intervals have passed without a heartbeat.
    presence_sweep(now=seen + timedelta(seconds=3 * told))
    robot.refresh_from_db()
    assert robot.presence == "unreachable"


def test_the_cap_never_shortens_a_sites_own_longer_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1
    settings.HEARTBEAT_INTERVAL_MAX = 4
    type(robot.site).objects.filter(pk=robot.site.pk).update(heartbeat_interval=6.0)
    robots_heartbeating(robot.site, 20)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 6.0
