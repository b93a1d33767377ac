"""A robot idle with its push channel open is told the idle interval (HEARTBEAT_IDLE_INTERVAL,
boards/services.py), over real HTTP: only when it says `push`, is idle with nothing on board and
nothing to report, and its answer brings no message; its presence follows the longer
interval, so it is not flipped for obeying."""

from datetime import timedelta

import pytest

from boards.services import board_post
from robots.selectors import robots_heartbeating_forget
from robots.services import presence_sweep
from tests import factories

IDLE = 5


@pytest.fixture(autouse=True)
def idle_interval(settings):
    robots_heartbeating_forget()
    settings.HEARTBEAT_IDLE_INTERVAL = IDLE
    yield
    robots_heartbeating_forget()


def test_an_idle_robot_with_the_push_channel_is_told_the_idle_interval_and_not_flipped(
    robot_http, robot
):
    told = robot_http.heartbeat(1, push=True)["heartbeat_interval"]

    assert told == factories.interval_told(robot, IDLE)  # spread over robots: 2.5 to 7.5 s
    seen = robot.last_seen_at
    assert robot.unreachable_at - seen == timedelta(seconds=3 * told)
    presence_sweep(now=seen + timedelta(seconds=3 * told - 0.01))  # past the site's 3 s
    robot.refresh_from_db()
    assert robot.presence == "online"


@pytest.mark.parametrize(
    "body",
    [
        {},
        {"push": False},
        {"push": True, "state": {"status": "moving"}},
        {"push": True, "state": {"status": "charging"}},
        {"push": True, "state": {"load": 1}},
        {"push": True, "events": [{"id": "e-idle-1", "type": "arrived"}]},
    ],
    ids=["no push", "push false", "moving", "charging", "loaded", "an event"],
)
def test_any_other_heartbeat_is_told_the_sites_interval(robot_http, body):
    assert robot_http.heartbeat(1, **body)["heartbeat_interval"] == 1.0


def test_an_answer_bringing_a_message_tells_the_sites_interval(robot_http, robot):
    board_post(robot=robot, type="action", body={"action": "pause"})

    answer = robot_http.heartbeat(1, push=True)

    assert [m["type"] for m in answer["messages"]] == ["action"]
    assert answer["heartbeat_interval"] == 1.0
    idle = factories.interval_told(robot, IDLE)  # its presence still follows the longer
    assert robot.unreachable_at - robot.last_seen_at == timedelta(seconds=3 * idle)


def test_a_sites_own_longer_interval_stands(robot_http, robot):
    robot.site.heartbeat_interval = 8.0
    robot.site.save(update_fields=["heartbeat_interval"])

    assert robot_http.heartbeat(1, push=True)["heartbeat_interval"] == 8.0


def test_with_no_idle_interval_set_every_robot_is_told_the_sites(robot_http, settings):
    settings.HEARTBEAT_IDLE_INTERVAL = 0

    assert robot_http.heartbeat(1, push=True)["heartbeat_interval"] == 1.0


def test_a_push_that_is_not_true_or_false_is_refused_naming_it(robot_http, robot):
    response = robot_http.post(factories.heartbeat_body(1, push="true"))

    assert response.status_code == 400
    assert response.json()["detail"] == {"push": ["Must be true or false."]}
    robot.refresh_from_db()
    assert robot.last_seen_at is None
