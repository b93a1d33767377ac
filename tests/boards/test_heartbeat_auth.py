"""Protocol v1: authentication, size limit and malformed bodies, over real HTTP."""

import json

import pytest

from boards.models import RobotEvent
from robots.models import Robot
from robots.services import robot_token_issue
from tests import factories


def assert_nothing_applied(robot):
    robot.refresh_from_db()
    assert robot.seq is None
    assert robot.last_seen_at is None
    assert not RobotEvent.objects.filter(robot=robot).exists()


def body_with_event(seq=1):
    return factories.heartbeat_body(
        seq, events=[{"id": "e-1", "type": "arrived", "at": "2026-11-22T09:13:58Z"}]
    )


def test_it_accepts_a_valid_heartbeat(robot_http, robot):
    reply = robot_http.heartbeat(1, state={"status": "moving", "battery": 0.5})

    assert reply["heartbeat_interval"] == 1.0
    assert reply["server_time"].endswith("Z")
    assert reply["messages"] == []
    robot.refresh_from_db()
    assert (robot.status, robot.battery, robot.seq, robot.presence) == ("moving", 0.5, 1, "online")


def test_it_refuses_a_missing_token_with_401(robot_http, robot):
    response = robot_http.post(body_with_event(), token="")

    assert response.status_code == 401
    assert response.headers["WWW-Authenticate"] == "Bearer"
    assert response.json()["error"] == "unauthorized"
    assert_nothing_applied(robot)


@pytest.mark.parametrize("header", ["Bearer not-a-token", "Basic dXNlcjpwYXNz", "Bearer"])
def test_it_refuses_a_wrong_token_with_401(robot_http, robot, header):
    response = robot_http.post(body_with_event(), token="", headers={"Authorization": header})

    assert response.status_code == 401
    assert_nothing_applied(robot)


def test_it_refuses_another_robots_token_with_403(robot_http, robot, site):
    other = factories.robot_create(site, "R2")

    response = robot_http.post(body_with_event(), token=other.token)

    assert response.status_code == 403
    assert response.json()["error"] == "forbidden"
    assert_nothing_applied(robot)
    assert_nothing_applied(other)


def test_it_refuses_a_revoked_token(robot_http, robot):
    old_token = robot.token
    robot.token = robot_token_issue(robot=Robot.objects.get(pk=robot.pk))

    assert robot_http.post(body_with_event(), token=old_token).status_code == 401
    assert robot_http.post(body_with_event()).status_code == 200


def test_it_stores_only_a_hash_of_the_token(robot):
    stored = Robot.objects.get(pk=robot.pk).token_hash
    assert stored
    assert robot.token not in stored


def test_it_refuses_a_body_over_64_kib_with_413(robot_http, robot):
    body = body_with_event()
    body["state"]["errors"] = ["x" * 200] * 40
    body["padding"] = "y" * (64 * 1024)

    response = robot_http.post(body)

    assert response.status_code == 413
    assert response.json()["error"] == "too_large"
    assert_nothing_applied(robot)


def chunked(body: bytes):
    return iter([body[: len(body) // 2], body[len(body) // 2 :]])


def test_it_reads_a_chunked_body_under_gunicorn(robot_gunicorn, robot):
    body = json.dumps(factories.heartbeat_body(1, state={"status": "charging"})).encode()

    response = robot_gunicorn.session.post(
        robot_gunicorn.url,
        data=chunked(body),
        headers={"Authorization": f"Bearer {robot.token}", "Content-Type": "application/json"},
    )

    assert response.status_code == 200, response.text
    robot.refresh_from_db()
    assert robot.status == "charging"


def test_it_refuses_a_chunked_body_over_64_kib(robot_gunicorn, robot):
    body = json.dumps(factories.heartbeat_body(1, padding="z" * (65 * 1024))).encode()

    response = robot_gunicorn.session.post(
        robot_gunicorn.url,
        data=chunked(body),
        headers={"Authorization": f"Bearer {robot.token}", "Content-Type": "application/json"},
    )

    assert response.status_code == 413
    assert_nothing_applied(robot)


@pytest.mark.parametrize(
    "raw", [b"{not json", b"", '{"boot_id": "\xe9"}'.encode("latin-1"), b"[1, 2"]
)
def test_it_refuses_invalid_json_with_400(robot_http, robot, raw):
    response = robot_http.post(raw=raw)

    assert response.status_code == 400
    assert response.json()["error"] == "invalid_json"
    assert "body" in response.json()["detail"]
    assert_nothing_applied(robot)


def replace(body, path, value):
    """Set body[path] where path is like 'state.battery' or 'events[0].type'; value None deletes."""
    *parents, last = path.replace("[", ".").replace("]", "").split(".")
    target = body
    for key in parents:
        target = target[int(key)] if key.isdigit() else target[key]
    if value is DELETE:
        del target[last]
    else:
        target[int(last) if last.isdigit() else last] = value
    return body


class Missing:
    def __repr__(self):
        return "<missing>"


DELETE = Missing()

MALFORMED = [
    ("boot_id", DELETE),
    ("boot_id", ""),
    ("boot_id", "b" * 65),
    ("boot_id", 17),
    ("seq", -1),
    ("seq", "3"),
    ("seq", True),
    ("seq", 1.5),
    ("seq", None),
    ("sent_at", "yesterday"),
    ("state", DELETE),
    ("state", "idle"),
    ("state.status", "dancing"),
    ("state.status", DELETE),
    ("state.floor", "99F"),
    ("state.floor", 1),
    ("state.waypoint", "NOWHERE"),
    ("state.x", "12.3"),
    ("state.heading", False),
    ("state.battery", 1.01),
    ("state.battery", -0.1),
    ("state.battery", "full"),
    ("state.battery", DELETE),
    ("state.load", -1),
    ("state.load", 1.5),
    ("state.plan_version", "7"),
    ("state.plan_version", -2),
    ("state.errors", "bumper"),
    ("state.errors", [1]),
    ("events", {"id": "e-1"}),
    ("events[0].id", DELETE),
    ("events[0].id", 5),
    ("events[0].type", "exploded"),
    ("events[0].at", "noon"),
    ("events[0].stop", -1),
    ("events[0].stop", "0"),
    ("events[0].resource", "NO-SUCH-LIFT"),
    ("acks", "m-1"),
    ("acks", [1]),
    ("requests", [{"id": "q-1", "type": "borrow", "resource": "ELEV"}]),
    ("requests", [{"id": "q-1", "type": "acquire", "resource": "NOPE"}]),
    ("requests", [{"id": "q-1", "type": "acquire", "resource": "ELEV", "to_floor": "9F"}]),
    ("requests", [{"type": "acquire", "resource": "ELEV"}]),
]


@pytest.mark.parametrize(("path", "value"), MALFORMED, ids=[f"{p}={v!r}" for p, v in MALFORMED])
def test_it_refuses_a_malformed_field_with_400_naming_it(robot_http, robot, path, value):
    body = replace(body_with_event(), path, value)

    response = robot_http.post(body)

    assert response.status_code == 400, response.text
    reply = response.json()
    assert reply["error"] == "invalid"
    named = path.split("[")[0] if path in ("events", "acks", "requests") else path
    assert any(field.startswith(named) for field in reply["detail"]), reply["detail"]
    assert_nothing_applied(robot)


def test_it_refuses_a_resource_event_without_its_resource(robot_http, robot):
    body = factories.heartbeat_body(1, events=[{"id": "e-1", "type": "resource_entered"}])

    response = robot_http.post(body)

    assert response.status_code == 400
    assert "events[0].resource" in response.json()["detail"]
    assert_nothing_applied(robot)


def test_it_refuses_more_than_500_events(robot_http, robot):
    events = [{"id": f"e-{n}", "type": "arrived"} for n in range(501)]

    response = robot_http.post(factories.heartbeat_body(1, events=events))

    assert response.status_code == 400
    assert "events" in response.json()["detail"]
    assert_nothing_applied(robot)


def test_it_refuses_a_body_that_is_not_an_object(robot_http, robot):
    response = robot_http.post([factories.heartbeat_body(1)])

    assert response.status_code == 400
    assert "body" in response.json()["detail"]


def test_it_ignores_unknown_fields_so_robots_may_add_some(robot_http, robot):
    body = factories.heartbeat_body(1, firmware="2.1.0", state={"temperature": 41})

    assert robot_http.post(body).status_code == 200
