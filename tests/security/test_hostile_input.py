"""Each hostile input found in issue 15 gets a 4xx in the documented shape, never a 500, and
changes nothing. Over real HTTP (live_server), as a robot or a hospital system sends them."""

import json

import pytest

from boards.models import RobotEvent
from scheduling.models import Task
from tests import factories

DEEP = b"[" * 3000
TASK = {
    "sender": "Pharmacy",
    "receiver": "Nurse Kim",
    "contents": "Insulin",
    "pickups": ["1F-PHARM"],
    "dropoffs": ["3F-WARD"],
}


def assert_refused(response, status: int, field: str | None = None) -> dict:
    assert response.status_code == status, response.text
    body = response.json()
    assert set(body) == {"error", "detail"}
    if field is not None:
        assert field in body["detail"], body
    return body


def assert_nothing_applied(robot):
    robot.refresh_from_db()
    assert robot.seq is None
    assert robot.last_seen_at is None
    assert not RobotEvent.objects.filter(robot=robot).exists()


def raw_heartbeat(**overrides) -> bytes:
    """A heartbeat body with JSON fragments spliced in verbatim ({"state.battery": "1e400"})."""
    body = factories.heartbeat_body(1)
    for n, path in enumerate(overrides):
        *parents, last = path.split(".")
        target = body
        for key in parents:
            target = target[key]
        target[last] = f"@@{n}@@"
    text = json.dumps(body)
    for n, fragment in enumerate(overrides.values()):
        text = text.replace(f'"@@{n}@@"', fragment)
    return text.encode()


@pytest.mark.parametrize(
    ("fragments", "field"),
    [
        ({"state.battery": "1" + "0" * 400}, "state.battery"),
        ({"state.battery": "-1" + "0" * 400}, "state.battery"),
        ({"state.x": "1e400"}, "state.x"),
        ({"state.status": '"\\ud800"'}, "state.status"),
        ({"state.errors": '["ok", "\\udfff"]'}, "state.errors[1]"),
        ({"boot_id": '"a\\u0000b"'}, "boot_id"),
        ({"seq": "9" * 30}, "seq"),
    ],
)
def test_it_refuses_hostile_state_with_400(robot_http, robot, fragments, field):
    response = robot_http.post(raw=raw_heartbeat(**fragments))

    assert_refused(response, 400, field)
    assert_nothing_applied(robot)


@pytest.mark.parametrize("code", ["T-²", "T-" + "9" * 25, "T-0", "T-١٢"])
def test_it_refuses_an_event_for_a_hostile_task_code(robot_http, robot, code):
    event = {"id": "e-1", "type": "task_received", "task": code}

    response = robot_http.post(factories.heartbeat_body(1, events=[event]))

    assert_refused(response, 400, "events[0].task")
    assert_nothing_applied(robot)


@pytest.mark.parametrize("ack", ["m-²", "m-" + "9" * 40, "m-" + "9" * 19])
def test_it_ignores_acks_of_hostile_message_ids(robot_http, robot, ack):
    # An ack of an unknown message is ignored (protocol v1); a hostile one is simply unknown.
    reply = robot_http.heartbeat(1, acks=[ack])

    assert reply["messages"] == []


@pytest.mark.parametrize("raw", [DEEP, b'{"a":' * 40 + b"1" + b"}" * 40])
def test_it_refuses_deeply_nested_heartbeats(robot_http, robot, raw):
    body = assert_refused(robot_http.post(raw=raw), 400, "body")

    assert body["error"] == "invalid_json"
    assert "nested deeper" in body["detail"]["body"][0]
    assert_nothing_applied(robot)


def test_it_refuses_a_waypoint_on_another_floor_than_the_state(robot_http, robot):
    response = robot_http.post(
        factories.heartbeat_body(1, state={"floor": "2F", "waypoint": "1F-DOCK-1"})
    )

    body = assert_refused(response, 400, "state.waypoint")
    assert "is on 1F" in body["detail"]["state.waypoint"][0]
    assert_nothing_applied(robot)


def test_it_still_accepts_brackets_inside_strings(robot_http, robot):
    robot_http.heartbeat(1, state={"errors": ["[" * 100 + "{" * 99]})

    robot.refresh_from_db()
    assert robot.seq == 1


@pytest.mark.parametrize("code", ["T-%C2%B2", "T-" + "9" * 25, "T-%00"])
def test_the_task_api_answers_404_for_hostile_codes(api_http, site, code):
    assert_refused(api_http.get(f"/api/v1/tasks/{code}"), 404 if "%00" not in code else 400)
    assert_refused(api_http.post(f"/api/v1/tasks/{code}/cancel"), 404 if "%00" not in code else 400)


def test_a_missing_task_answers_a_flat_404(api_http, site):
    body = assert_refused(api_http.get("/api/v1/tasks/T-0042"), 404)

    assert body["error"] == "not_found"
    assert isinstance(body["detail"], str)


def test_a_missing_robot_answers_a_flat_404(api_http, site):
    body = assert_refused(api_http.get("/api/v1/robots/R99"), 404)

    assert isinstance(body["detail"], str)


def test_the_deliveries_page_answers_404_for_hostile_codes(nurse_http, site):
    for code in ["T-%C2%B2", "T-" + "9" * 25]:
        assert nurse_http.get(f"/deliveries/{code}/").status_code == 404
    assert nurse_http.get("/robots/%00/").status_code == 400


def test_the_robot_list_bounds_its_page_size(api_http, site):
    for n in range(3):
        factories.robot_create(site, f"R{n}")

    response = api_http.get("/api/v1/robots/?limit=99999999999999999999")

    assert response.status_code == 200, response.text
    assert len(response.json()["results"]) == 3
    assert_refused(api_http.get("/api/v1/robots/?offset=99999999999999999999"), 400, "offset")


@pytest.mark.parametrize(
    ("raw", "field"),
    [
        (DEEP, "body"),
        (b'{"sender": "a", "priority": "\\ud800"}', "priority"),
        (b'{"sender": "\\u0000"}', "sender"),
        (b'{"site": "x", "\\udc80": 1}', "\\udc80"),
    ],
)
def test_the_task_api_refuses_hostile_bodies(api_http, site, raw, field):
    body = assert_refused(api_http.post("/api/v1/tasks/", raw=raw), 400, field)

    assert body["error"] == "invalid_json"
    assert not Task.objects.exists()


def test_the_task_api_refuses_a_body_over_its_limit_in_json(api_http, site):
    raw = json.dumps({**TASK, "contents": "x" * (3 * 1024 * 1024)}).encode()

    assert_refused(api_http.post("/api/v1/tasks/", raw=raw), 413)
    assert not Task.objects.exists()
