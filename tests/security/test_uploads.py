"""Map uploads cannot be turned against the server: YAML whose aliases expand a few hundred
bytes into millions of values, and deep nesting (a RecursionError, once a 500), are refused
with a 400 naming why, while the aliases a real site file uses still load; and the map Check
refuses coordinates far off any floor."""

import copy
import time

import pytest
from django.test import Client

from robots.sitefile import COORDINATE_LIMIT
from tests.maps.test_api import DRAFT, draft, post, put
from tests.servers import REPO

pytestmark = pytest.mark.django_db


def alias_bomb(levels: int = 7) -> str:
    """Each level repeats the one before ten times: a few hundred bytes, ten million cells
    once expanded."""
    names = "abcdefghij"[:levels]
    lines = [f"{names[0]}: &{names[0]} [{', '.join(['lol'] * 10)}]"]
    for before, name in zip(names, names[1:], strict=False):
        lines.append(f"{name}: &{name} [{', '.join(['*' + before] * 10)}]")
    return "\n".join(lines) + "\n"


ALIAS_BOMB = alias_bomb()


@pytest.fixture
def admin_client(staff):
    client = Client()
    client.force_login(staff)
    return client


def upload(client, text: str, name: str = "site.yaml"):
    return post(client, f"{DRAFT}/upload", {"revision": 1, "name": name, "text": text})


@pytest.mark.parametrize(
    ("name", "text", "why"),
    [
        ("bomb.yaml", ALIAS_BOMB, "once its aliases (*name) are expanded"),
        ("loop.yaml", "site: tiny\nfloors: &f [*f]\n", "nested deeper"),
        ("deep.yaml", "site: tiny\nfloors: " + "[" * 1500 + "]" * 1500 + "\n", "nested deeper"),
        ("deep.json", '{"site": "tiny", "floors": ' + "[" * 1500 + "]" * 1500 + "}", "nested"),
        ("deep.yml", "site: tiny\nx: " + "{a: " * 200 + "1" + "}" * 200 + "\n", "nested deeper"),
    ],
)
def test_hostile_uploads_are_refused_naming_why(site, admin_client, name, text, why):
    before = draft(admin_client)
    started = time.perf_counter()

    response = upload(admin_client, text, name)

    assert response.status_code == 400, response.content[:300]
    assert why in response.json()["detail"]["text"][0]
    assert time.perf_counter() - started < 5  # nothing was expanded
    assert draft(admin_client) == before


def test_the_bomb_is_small_and_a_site_files_own_aliases_still_load(site, admin_client):
    assert len(ALIAS_BOMB) < 500
    text = (REPO / "sites" / "eulji.yaml").read_text()
    assert "*locking" in text  # robots sharing one list of compartments

    assert upload(admin_client, text.replace("site: eulji", "site: tiny")).status_code == 200


@pytest.mark.parametrize(("axis", "value"), [("x", 1e15), ("y", -1e6), ("x", COORDINATE_LIMIT + 1)])
def test_the_check_refuses_a_waypoint_far_off_its_floor(site, admin_client, axis, value):
    document = copy.deepcopy(draft(admin_client)["document"])
    document["floors"][0]["waypoints"][0][axis] = value
    assert put(admin_client, {"revision": 1, "document": document}).status_code == 200

    problems = admin_client.get(f"{DRAFT}/check").json()["problems"]

    assert any(f"waypoints[0].{axis}" in problem and "must be" in problem for problem in problems)
