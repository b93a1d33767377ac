"""The pages' re-read after (re)connecting: /live/<site>/state.json."""

import pytest

from robots.alerts import alert_raise
from robots.models import AlertKind
from tests import factories
from tests.scheduling.conftest import request, robot_ready

ROBOT_KEYS = {
    "code",
    "presence",
    "presence_label",
    "status",
    "status_label",
    "floor",
    "floor_name",
    "waypoint",
    "place",
    "x",
    "y",
    "heading",
    "battery",
    "load",
    "capacity",
    "errors",
    "paused_by_operator",
    "held_after_fault",
    "sent_to_charge",
    "in_maintenance",
    "last_seen_at",
}


@pytest.fixture
def state(nurse_client, site):
    def read(**params):
        response = nurse_client.get(f"/live/{site.code}/state.json", params)
        assert response.status_code == 200, response.content
        assert response["Cache-Control"].startswith("max-age=0")
        return response.json()

    return read


def test_it_returns_every_part_and_the_robots_state(state, site):
    robot_ready(factories.robot_create(site, "R1"), at="2F-LAB", battery=0.831)
    task = request(site)
    alert_raise(site_id=site.pk, kind=AlertKind.ROBOT_ERROR, key="k", message="R1 is stuck")

    body = state()

    assert set(body["parts"]) == {"schedule", "fleet", "resources", "alerts"}
    assert f'data-task="{task.code}"' in body["parts"]["schedule"]
    assert 'data-robot="R1"' in body["parts"]["fleet"]
    assert 'data-resource="ELEV"' in body["parts"]["resources"]
    assert "R1 is stuck" in body["parts"]["alerts"]
    [robot] = body["robots"]
    assert set(robot) == ROBOT_KEYS
    assert robot["floor"] == "2F"
    assert (robot["waypoint"], robot["place"]) == ("2F-LAB", "Laboratory")
    assert (robot["x"], robot["y"]) == (20.0, 30.0)  # the waypoint's, none reported
    assert robot["battery"] == 83


def test_it_returns_only_the_parts_asked_for(state, site):
    assert set(state(parts="schedule,alerts")["parts"]) == {"schedule", "alerts"}


def test_it_returns_a_robots_panels_and_state(state, site):
    robot_ready(factories.robot_create(site, "R1"))

    body = state(parts="robot", robot="R1")

    assert "Current plan" in body["parts"]["robot"]
    assert [robot["code"] for robot in body["robots"]] == ["R1"]


@pytest.mark.parametrize("params", [{"parts": "everything"}, {"parts": "robot", "robot": "R9"}])
def test_it_answers_404_for_unknown_parts_and_robots(nurse_client, site, params):
    assert nurse_client.get(f"/live/{site.code}/state.json", params).status_code == 404


def test_it_answers_404_for_an_unknown_site(nurse_client, site):
    assert nurse_client.get("/live/nowhere/state.json").status_code == 404
