"""A fire alarm over the API (a building management system signed in as an operator) and on the
fleet page: one confirmed action each way; bad input is a 4xx naming the field, changing
nothing; every page of the site shows it."""

import pytest
from django.core.management import call_command
from django.test import Client

from boards.models import BoardMessage
from hospital_delivery.models import ApiToken
from robots.models import Alert, Emergency
from tests import factories
from tests.scheduling.conftest import robot_ready

URL = "/api/v1/sites/tiny/fire-alarm"


@pytest.fixture
def building(site):
    """The building management system's account: an operator of the site with an API token."""
    user = factories.user_create("bms", "operator")
    user.api_token_plain = ApiToken.issue(user)
    return user


@pytest.fixture
def api(building):
    return Client(HTTP_AUTHORIZATION=f"Bearer {building.api_token_plain}")


def post(client, path="", body=None):
    return client.post(f"{URL}{path}", body, content_type="application/json")


def unchanged(site) -> bool:
    site.refresh_from_db()
    quiet = not BoardMessage.objects.filter(type="action").exists()
    return site.fire_alarm_since is None and not Emergency.objects.exists() and quiet


def test_a_building_system_starts_and_ends_it(api, site, building):
    robot_ready(factories.robot_create(site, "R1"))
    assert api.get(URL).json()["active"] is False

    started = post(api, body={"floors": ["1F", "2F"], "reason": "detector zone 3"})

    assert started.status_code == 201, started.content
    body = started.json()
    assert body | {"started_at": None} == {
        "site": "tiny",
        "active": True,
        "floors": ["1F", "2F"],
        "reason": "detector zone 3",
        "started_at": None,
        "started_by": "bms",
        "started_via": "api",
        "stopped_robots": ["R1"],
        "refuges": {},
    }
    assert api.get(URL).json()["active"] is True
    again = post(api, body={})
    assert (again.status_code, again.json()["error"]) == (409, "conflict")

    cleared = post(api, "/all-clear")
    assert cleared.status_code == 200, cleared.content
    assert cleared.json()["active"] is False
    assert post(api, "/all-clear").status_code == 409
    alarm = Emergency.objects.get()
    assert (alarm.ended_by, alarm.ended_via) == (building, "api")


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"floors": ["9F"]}, "floors"),
        ({"floors": "1F"}, "floors"),
        ({"floors": [1]}, "floors[0]"),
        ({"reason": 5}, "reason"),
        ({"reason": "x" * 201}, "reason"),
    ],
)
def test_bad_input_is_refused_naming_the_field(api, site, body, field):
    robot_ready(factories.robot_create(site, "R1"))
    refused = post(api, body=body)
    assert refused.status_code == 400, refused.content
    assert refused.json()["error"] == "invalid"
    assert field in refused.json()["detail"]
    assert unchanged(site)


def test_only_operators_of_the_site_may(site, nurse):
    assert Client().post(URL, {}, content_type="application/json").status_code == 401
    nurse.api_token_plain = ApiToken.issue(nurse)
    as_nurse = Client(HTTP_AUTHORIZATION=f"Bearer {nurse.api_token_plain}")
    assert post(as_nurse, body={}).status_code == 403
    stranger = factories.user_create("elsewhere", "operator", sites=[])
    stranger_api = Client(HTTP_AUTHORIZATION=f"Bearer {ApiToken.issue(stranger)}")
    assert post(stranger_api, body={}).status_code == 404
    assert unchanged(site)


def test_an_operator_starts_it_on_the_fleet_page_and_every_page_shows_it(site, operator, nurse):
    page = Client()
    page.force_login(operator)
    fleet = page.get("/fleet/?site=tiny")
    assert b"Start fire alarm" in fleet.content

    started = page.post("/sites/tiny/fire-alarm", {"start": "true", "floors": ["3F"]})
    assert started.status_code == 302
    alarm = Emergency.objects.get()
    assert (alarm.floors, alarm.started_by, alarm.started_via) == (["3F"], operator, "operator")

    ward = Client()
    ward.force_login(nurse)
    shown = ward.get("/").content.decode()
    assert "Fire alarm on floors 3F" in shown
    assert "All clear" in page.get("/fleet/?site=tiny").content.decode()
    # Its notice cannot be acknowledged away while it is in force.
    alert = Alert.objects.open().get(kind="fire_alarm")
    page.post(f"/alerts/{alert.pk}/acknowledge")
    assert Alert.objects.open().filter(pk=alert.pk).exists()

    page.post("/sites/tiny/fire-alarm", {"start": "false"})
    assert Emergency.objects.get().ended_by == operator
    assert "Fire alarm on floors" not in ward.get("/").content.decode()


def test_the_page_refuses_an_unknown_floor_naming_it(site, operator):
    page = Client()
    page.force_login(operator)
    refused = page.post("/sites/tiny/fire-alarm", {"start": "true", "floors": ["9F"]})
    assert refused.status_code == 400
    assert "floors" in refused.json()["detail"]
    assert unchanged(site)


def test_an_operator_is_issued_a_token_for_it(site, capsys):
    factories.user_create("fire-panel", "operator")
    call_command("user_token", "fire-panel")
    token = capsys.readouterr().out.strip()
    panel = Client(HTTP_AUTHORIZATION=f"Bearer {token}")
    assert panel.get(URL).status_code == 200
    assert panel.get("/api/v1/tasks/").status_code == 403  # nothing else of the API
