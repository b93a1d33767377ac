"""The hospital's own words for its places: a site file may name a floor, a station or a
resource per language; pages show the viewer's language, robots and the API the default name."""

import copy

import pytest
from django.test import Client

from maps.diff import map_diff
from maps.documents import site_document
from robots.sitefile import site_file_validate, site_load
from tests import factories
from tests.scheduling.conftest import request as order_task
from tests.ui.conftest import logged_in

KOREAN_LAB = "진단검사실"
ITALIAN_LAB = "Laboratorio analisi"


def named(data: dict) -> dict:
    data = copy.deepcopy(data)
    second = data["floors"][1]
    second["names"] = {"ko": "2층 검사동", "it": "Secondo piano, laboratori"}
    lab = next(wp for wp in second["waypoints"] if wp["code"] == "2F-LAB")
    lab["names"] = {"ko": KOREAN_LAB, "it": ITALIAN_LAB}
    return data


@pytest.fixture
def site(db, nurse):
    return factories.site_create(**named(factories.TINY_SITE))


@pytest.mark.parametrize(
    ("language", "name"), [("ko", KOREAN_LAB), ("it", ITALIAN_LAB), ("en", "Laboratory")]
)
def test_a_station_is_named_in_the_viewers_language(site, nurse, language, name):
    page = logged_in(nurse).get("/stations/2F-LAB/", HTTP_ACCEPT_LANGUAGE=language)

    assert page.status_code == 200
    assert f'<h1 id="station-title">{name}</h1>' in page.content.decode()


def test_a_floor_is_named_in_the_viewers_language(site, nurse):
    page = logged_in(nurse).get("/fleet/?floor=2F", HTTP_ACCEPT_LANGUAGE="ko")

    assert "2층 검사동" in page.content.decode()


def test_the_schedule_names_the_drop_off_in_korean(site, nurse):
    order_task(site, dropoffs=("2F-LAB",))

    page = logged_in(nurse).get("/", HTTP_ACCEPT_LANGUAGE="ko")

    assert KOREAN_LAB in page.content.decode()


def test_the_api_keeps_the_default_name_and_the_code(site, staff):
    task = order_task(site, dropoffs=("2F-LAB",))
    client = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")

    answer = client.get(f"/api/v1/tasks/{task.code}", HTTP_ACCEPT_LANGUAGE="ko").json()

    assert {"waypoint": "2F-LAB", "station": "Laboratory"}.items() <= answer["stops"][-1].items()


def test_names_in_a_language_the_pages_do_not_speak_are_refused_naming_the_key(db):
    data = named(factories.TINY_SITE)
    data["floors"][1]["names"]["fr"] = "Laboratoire"

    assert site_file_validate(data) == [
        "floors[1].names: 'fr' is not a language of the pages (one of en, ko, it)"
    ]


def test_an_empty_name_is_refused(db):
    data = named(factories.TINY_SITE)
    data["floors"][1]["waypoints"][3]["names"]["ko"] = " "

    assert site_file_validate(data) == [
        "floors[1].waypoints[3].names: ko: must be a name of 1 to 200 characters"
    ]


def test_names_go_out_with_the_site_file_and_come_back_unchanged(site):
    exported = site_document(site)

    again = site_load(data=exported)

    assert again.waypoints.get(code="2F-LAB").names == {"ko": KOREAN_LAB, "it": ITALIAN_LAB}
    assert map_diff(exported, site_document(again)).changes == []


def test_a_changed_name_in_one_language_is_a_change_to_review(site):
    live = site_document(site)
    draft = copy.deepcopy(live)
    waypoints = [wp for floor in draft["floors"] for wp in floor["waypoints"]]
    lab = next(wp for wp in waypoints if wp["code"] == "2F-LAB")
    lab["names"]["ko"] = "검체 접수"

    changes = map_diff(live, draft).changes

    assert [(c.what, c.how, c.code, c.detail) for c in changes] == [
        ("waypoint", "renamed", "2F-LAB", f"ko: '{KOREAN_LAB}' → '검체 접수'")
    ]
