"""The map editor's JSON API: administrators only, the error shape of core/errors.py, and
bad input changes nothing."""

import copy

import pytest
from django.test import Client

from maps.documents import document_yaml, site_document
from maps.models import MapDraft, MapVersion
from robots.models import Site
from tests import factories

DRAFT = "/api/v1/maps/tiny/draft"


@pytest.fixture
def admin_client(staff):
    client = Client()
    client.force_login(staff)
    return client


def put(client, body, url=DRAFT):
    return client.put(url, body, content_type="application/json")


def post(client, url, body):
    return client.post(url, body, content_type="application/json")


def draft(client) -> dict:
    response = client.get(DRAFT)
    assert response.status_code == 200, response.content
    return response.json()


def test_it_lets_only_administrators_near_the_map(site, nurse, operator):
    assert Client().get(DRAFT).status_code == 401
    for user in (nurse, operator):
        client = Client()
        client.force_login(user)
        response = client.get(DRAFT)
        assert response.status_code == 403
        assert response.json()["error"] == "forbidden"
    assert not MapDraft.objects.exists()


def test_it_starts_the_draft_from_the_live_map(site, admin_client):
    body = draft(admin_client)

    assert body["revision"] == 1
    assert body["base_version"] == 1
    assert body["document"] == site_document(site)
    assert admin_client.get("/api/v1/maps/nowhere/draft").status_code == 404


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"document": {"site": "tiny", "floors": []}}, "revision"),
        ({"revision": "1", "document": {"site": "tiny", "floors": []}}, "revision"),
        ({"revision": 1, "document": ["not", "a", "mapping"]}, "document"),
        ({"revision": 1}, "document"),
        ({"revision": 1, "document": {"site": "elsewhere", "floors": []}}, "document.site"),
        ({"revision": 1, "document": {}, "rollout": "maybe"}, "rollout"),
    ],
)
def test_it_refuses_a_bad_draft_naming_the_field_and_changes_nothing(
    site, admin_client, body, field
):
    before = draft(admin_client)

    response = put(admin_client, body)

    assert response.status_code == 400, response.content
    assert response.json()["error"] == "invalid"
    assert field in response.json()["detail"]
    assert draft(admin_client) == before


def test_it_refuses_a_save_over_someone_elses_with_409(site, admin_client):
    document = draft(admin_client)["document"]
    assert put(admin_client, {"revision": 1, "document": document}).status_code == 200

    response = put(admin_client, {"revision": 1, "document": {**document, "name": "Lost"}})

    assert response.status_code == 409
    assert list(response.json()["detail"]) == ["revision"]
    assert draft(admin_client)["document"]["name"] == "Tiny test hospital"


def test_it_refuses_to_publish_an_invalid_draft_naming_every_problem_by_place(site, admin_client):
    document = copy.deepcopy(draft(admin_client)["document"])
    first = next(n for n, f in enumerate(document["floors"]) if f["code"] == "1F")
    document["floors"][first]["edges"].append(["1F-PHARM", "1F-NOWHERE"])
    document["floors"][first]["waypoints"].append({"code": "1F-HALL", "x": 0, "y": 0})
    revision = put(admin_client, {"revision": 1, "document": document}).json()["revision"]

    response = post(admin_client, f"{DRAFT}/publish", {"revision": revision, "note": "bad"})

    assert response.status_code == 400
    detail = response.json()["detail"]
    edges = f"document.floors[{first}].edges[4]"
    assert detail[edges] == ["unknown waypoint '1F-NOWHERE'"]
    duplicate = detail[f"document.floors[{first}].waypoints[5].code"]
    assert duplicate == [f"duplicate code '1F-HALL' (also floors[{first}].waypoints[3])"]
    assert Site.objects.get(pk=site.pk).map_version == 1
    assert not MapVersion.objects.filter(number=2).exists()
    check = admin_client.get(f"{DRAFT}/check").json()
    assert len(check["problems"]) == 2


def test_it_takes_an_uploaded_site_file_into_the_draft_and_shows_its_changes(site, admin_client):
    document = copy.deepcopy(site_document(site))
    document["floors"][0]["waypoints"][0]["x"] = 1.5
    text = document_yaml(document)

    response = post(
        admin_client, f"{DRAFT}/upload", {"revision": 1, "name": "tiny.yaml", "text": text}
    )

    assert response.status_code == 200, response.content
    check = admin_client.get(f"{DRAFT}/check").json()
    assert check["problems"] == []
    moved = [c for c in check["changes"] if c["how"] == "moved"]
    assert [c["code"] for c in moved] == [document["floors"][0]["waypoints"][0]["code"]]


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("site: tiny\nsite: tiny\n", "text"),
        ("- just\n- a list\n", "text"),
        ("site: tiny\nname: \x00\n", "text"),
        ("site: [unclosed\n", "text"),
        ("site: elsewhere\nfloors: []\n", "document.site"),
    ],
)
def test_it_refuses_a_bad_upload_and_keeps_the_draft(site, admin_client, text, field):
    before = draft(admin_client)

    response = post(
        admin_client, f"{DRAFT}/upload", {"revision": 1, "name": "x.yaml", "text": text}
    )

    assert response.status_code == 400, response.content
    assert field in response.json()["detail"]
    assert draft(admin_client) == before


def test_it_publishes_lists_and_rolls_back_versions(site, admin_client):
    document = copy.deepcopy(draft(admin_client)["document"])
    document["name"] = "Renamed hospital"
    revision = put(admin_client, {"revision": 1, "document": document}).json()["revision"]

    published = post(admin_client, f"{DRAFT}/publish", {"revision": revision, "note": "rename"})

    assert published.status_code == 201, published.content
    assert published.json()["number"] == 2
    versions = admin_client.get("/api/v1/maps/tiny/versions").json()
    assert [(v["number"], v["note"]) for v in versions][0] == (2, "rename")
    assert versions[0]["author"] == "operator"
    rolled = post(admin_client, "/api/v1/maps/tiny/versions/1/restore", {})
    assert rolled.status_code == 201
    assert rolled.json()["restored_from"] == 1
    assert Site.objects.get(pk=site.pk).name == "Tiny test hospital"
    missing = post(admin_client, "/api/v1/maps/tiny/versions/99/restore", {})
    assert missing.status_code == 404


def test_it_tells_robots_the_new_map_version_in_their_heartbeat_answer(site, robot, admin_client):
    def heartbeat(seq):
        response = Client().post(
            f"/api/v1/robots/{robot.code}/heartbeat",
            factories.heartbeat_body(seq),
            content_type="application/json",
            HTTP_AUTHORIZATION=f"Bearer {robot.token}",
        )
        assert response.status_code == 200, response.content
        return response.json()

    assert heartbeat(1)["map_version"] == 1
    document = copy.deepcopy(draft(admin_client)["document"])
    document["floors"][-1]["waypoints"][2]["name"] = "Main hall"
    revision = put(admin_client, {"revision": 1, "document": document}).json()["revision"]
    assert post(admin_client, f"{DRAFT}/publish", {"revision": revision}).status_code == 201

    assert heartbeat(2)["map_version"] == 2


def test_it_checks_a_draft_holding_anything_without_failing(site, admin_client):
    garbage = {
        "site": "tiny",
        "floors": [
            {"code": "1F", "waypoints": [{"code": "A", "x": [1], "y": {}}, 7, {"code": ["B"]}]},
            {"code": "2F", "level": "two", "edges": [5, [1], {"to": "x"}, ["A"], None]},
            "not a floor",
        ],
        "resources": "none",
        "robots": [{"code": "R9", "dock": "A"}],
    }
    assert put(admin_client, {"revision": 1, "document": garbage}).status_code == 200

    response = admin_client.get(f"{DRAFT}/check")

    assert response.status_code == 200, response.content
    check = response.json()
    assert len(check["problems"]) > 5
    assert {
        "what": "waypoint",
        "how": "added",
        "code": "A",
        "detail": "plain on 1F at ([1], {})",
    } in check["changes"]
    published = post(admin_client, f"{DRAFT}/publish", {"revision": 2})
    assert published.status_code == 400
    assert Site.objects.get(pk=site.pk).map_version == 1


def test_it_serves_the_map_load_site_made_as_its_version(admin_client, site):
    assert not MapVersion.objects.exists()

    first = admin_client.get("/api/v1/maps/tiny/versions/1")
    again = admin_client.get("/api/v1/maps/tiny/versions/1")

    assert first.status_code == again.status_code == 200, first.content
    assert first.json()["document"] == site_document(site)
    assert MapVersion.objects.get().number == 1  # kept once
    missing = admin_client.get("/api/v1/maps/tiny/versions/2")
    assert (missing.status_code, missing.json()["error"]) == (404, "not_found")
