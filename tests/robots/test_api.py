"""The device catalog (GET /api/v1/robots/...) and the OpenAPI schema, over real HTTP."""

import pytest
import requests
from django.core.management import call_command

from tests import factories


@pytest.fixture
def api(live_server):
    def get(path, *, token=None, session=None):
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        return (session or requests).get(f"{live_server.url}{path}", headers=headers, timeout=30)

    return get


def test_it_lists_robots_with_presence_and_last_state(api, robot_http, robot, staff):
    robot_http.heartbeat(1, state={"status": "moving", "floor": "2F", "battery": 0.7})

    response = api("/api/v1/robots/", token=staff.api_token_plain)

    assert response.status_code == 200, response.text
    [listed] = response.json()["results"]
    assert listed["code"] == "R1"
    assert listed["presence"] == "online"
    assert listed["last_seen_at"]
    assert listed["state"]["status"] == "moving"
    assert listed["state"]["floor"] == "2F"
    assert listed["state"]["battery"] == 0.7
    assert listed["dock"] == "1F-DOCK-1"


def test_it_shows_one_robot(api, robot, staff):
    response = api("/api/v1/robots/R1", token=staff.api_token_plain)

    assert response.status_code == 200
    assert response.json()["presence"] == "offline"
    assert response.json()["paused_by_operator"] is False
    assert response.json()["state"]["status"] == "unknown"


def test_it_answers_404_for_an_unknown_robot(api, robot, staff):
    response = api("/api/v1/robots/R99", token=staff.api_token_plain)

    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


def test_it_accepts_a_staff_session(api, live_server, robot, staff):
    session = requests.Session()
    login_page = session.get(f"{live_server.url}/admin/login/", timeout=30)
    assert login_page.status_code == 200
    session.post(
        f"{live_server.url}/admin/login/",
        data={
            "username": staff.username,
            "password": "pw-12345!",
            "csrfmiddlewaretoken": session.cookies["csrftoken"],
        },
        headers={"Referer": f"{live_server.url}/admin/login/"},
        timeout=30,
    )

    assert api("/api/v1/robots/", session=session).status_code == 200


def test_it_refuses_anonymous_and_non_staff_users(api, robot, db):
    nurse = factories.staff_create("nurse", is_staff=False)

    assert api("/api/v1/robots/").status_code == 401
    assert api("/api/v1/robots/", token="wrong").status_code == 401
    assert api("/api/v1/robots/", token=nurse.api_token_plain).status_code == 403


def test_it_refuses_a_robot_token_for_the_catalog(api, robot):
    assert api("/api/v1/robots/", token=robot.token).status_code == 401


def test_a_new_user_token_revokes_the_old_one(api, robot, staff, capsys):
    call_command("user_token", staff.username)
    new_token = capsys.readouterr().out.strip()

    assert api("/api/v1/robots/", token=staff.api_token_plain).status_code == 401
    assert api("/api/v1/robots/", token=new_token).status_code == 200


def test_the_robot_token_command_prints_a_working_token_once(robot_http, robot, capsys):
    call_command("robot_token", "R1")
    token = capsys.readouterr().out.strip()

    assert robot_http.post(factories.heartbeat_body(1), token=token).status_code == 200
    assert robot_http.post(factories.heartbeat_body(2), token=robot.token).status_code == 401


def test_the_schema_describes_the_heartbeat(api, staff):
    response = api("/api/schema/?format=json", token=staff.api_token_plain)

    assert response.status_code == 200
    schema = response.json()
    operation = schema["paths"]["/api/v1/robots/{robot}/heartbeat"]["post"]
    assert set(operation["responses"]) == {"200", "400", "401", "403", "413"}
    request_schema = schema["components"]["schemas"]["HeartbeatRequest"]
    assert set(request_schema["required"]) == {"boot_id", "seq", "state"}
    state = schema["components"]["schemas"]["HeartbeatStateRequest"]
    assert state["properties"]["battery"]["maximum"] == 1.0
    assert "/api/v1/robots/{robot}" in schema["paths"]


def test_the_schema_generates_without_warnings():
    call_command("spectacular", "--validate", "--fail-on-warn", "--file", "/dev/null")
