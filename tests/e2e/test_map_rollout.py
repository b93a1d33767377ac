"""A published map reaching a running fleet, end to end: the production stack (bench/stack.py:
gunicorn, daphne, a Celery worker and beat on the test database) and simulated robots
(robotsim.fleet) driving at 25x. The administrator works through the map API over HTTP, as the
editor page does.

* A station added and published is where a nurse's delivery goes at once, and a robot given
  the new site file (as a robot fetches it when map_version changes) carries it there.
* A map that cuts the route of a robot out delivering is refused while it drives, the delivery
  completes, the same map is published once the robot is home, and rolling back restores the
  map before it.
* With the site's choice "re-plan", the same map is published while the robot drives: it is
  posted a plan routed on the new map, takes the new map (map_version) at its next waypoint,
  and delivers without a heartbeat refused for a code the server no longer knows.
"""

import copy

import pytest
import requests

from bench.stack import Stack
from maps.models import MapVersion
from robots.mapcache import site_map
from robots.models import Site
from robotsim.fleet import Fleet, FleetConfig, RobotSpec
from robotsim.traffic import HttpMapSource, HttpTaskApi
from scheduling.models import Task
from tests import factories, servers

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


@pytest.fixture
def stack(transactional_db):
    with Stack(database_url=servers.test_database_url(), web_workers=2, beat=True) as stack:
        yield stack


class MapApi:
    """The map API over HTTP with an administrator's token."""

    def __init__(self, server_url: str, token: str):
        self.url = f"{server_url}/api/v1/maps/tiny"
        self.session = requests.Session()
        self.session.headers["Authorization"] = f"Bearer {token}"

    def draft(self) -> dict:
        response = self.session.get(f"{self.url}/draft", timeout=10)
        assert response.status_code == 200, response.text
        return response.json()

    def publish(self, document: dict, note: str, rollout: str = "refuse") -> requests.Response:
        revision = self.draft()["revision"]
        body = {"revision": revision, "document": document, "rollout": rollout}
        saved = self.session.put(f"{self.url}/draft", json=body, timeout=10)
        assert saved.status_code == 200, saved.text
        body = {"revision": saved.json()["revision"], "note": note}
        return self.session.post(f"{self.url}/draft/publish", json=body, timeout=30)

    def restore(self, number: int) -> requests.Response:
        return self.session.post(f"{self.url}/versions/{number}/restore", json={}, timeout=30)


def fleet_of(stack, site, document: dict, map_source=None) -> Fleet:
    robot = factories.robot_create(site, "R1", dock=site.waypoints.get(code="1F-DOCK-1"))
    spec = RobotSpec(code=robot.code, token=robot.token, dock="1F-DOCK-1")
    config = FleetConfig(
        server_url=stack.http_url,
        ws_url=stack.ws_url,
        site=document,
        robots=(spec,),
        speedup=25,
        map_source=map_source,
    )
    return Fleet(config)


def floor(document: dict, code: str) -> dict:
    return next(f for f in document["floors"] if f["code"] == code)


def order(stack, staff, pickup: str, dropoff: str) -> str:
    body = {"sender": "Pharmacy", "receiver": "Ward", "contents": "Medication"}
    api = HttpTaskApi(stack.http_url, staff.api_token_plain)
    status, reply = api.post({**body, "pickups": [pickup], "dropoffs": [dropoff]})
    assert status == 201, reply
    return reply["code"]


def status_of(code: str) -> str:
    return Task.objects.get(pk=int(code[2:])).status


def test_a_robot_carries_a_delivery_to_a_station_just_published(stack, site, staff):
    maps = MapApi(stack.http_url, staff.api_token_plain)
    document = copy.deepcopy(maps.draft()["document"])
    floor(document, "2F")["waypoints"].append(
        {"code": "2F-XRAY", "x": 30, "y": 0, "kind": "station", "name": "X-ray"}
    )
    floor(document, "2F")["edges"].append(["2F-ELEV-WAIT", "2F-XRAY"])

    published = maps.publish(document, "X-ray reception opens")

    assert published.status_code == 201, published.text
    new_file = MapVersion.objects.get(site=site, number=published.json()["number"]).document
    fleet = fleet_of(stack, site, new_file)
    fleet.start()
    try:
        code = order(stack, staff, "1F-PHARM", "2F-XRAY")
        servers.poll(
            lambda: status_of(code) == "completed",
            timeout=150,
            interval=0.2,
            what="the delivery to the new station completed",
        )
        assert fleet.errors == []
        assert all(loop.refused == 0 for loop in fleet.loops)
    finally:
        fleet.stop()


def without_the_corridor_middle(document: dict) -> dict:
    """3F's corridor rebuilt with its middle waypoint moved and renamed: routes to the ward
    cross 3F-CORR-MID, which the new map no longer has."""
    document = copy.deepcopy(document)
    third = floor(document, "3F")
    for wp in third["waypoints"]:
        if wp["code"] == "3F-CORR-MID":
            wp.update(code="3F-CORR-MID-2", y=1.0)
    third["edges"] = [[c.replace("MID", "MID-2") for c in edge] for edge in third["edges"]]
    corridor = next(r for r in document["resources"] if r["code"] == "CORR-3F")
    corridor["guards"] = [[c.replace("MID", "MID-2") for c in pair] for pair in corridor["guards"]]
    return document


def test_a_map_cutting_a_driving_robots_route_waits_for_it_and_rolls_back(stack, site, staff):
    maps = MapApi(stack.http_url, staff.api_token_plain)
    live = maps.draft()["document"]
    fleet = fleet_of(stack, site, live)
    fleet.start()
    try:
        code = order(stack, staff, "1F-PHARM", "3F-WARD")
        servers.poll(
            lambda: status_of(code) == "picked_up",
            timeout=90,
            interval=0.1,
            what="the robot on its way to the ward",
        )

        refused = maps.publish(without_the_corridor_middle(live), "corridor works")

        assert refused.status_code == 409, refused.text
        assert refused.json()["detail"]["routes"] == [
            {"robot": "R1", "crosses": ["waypoint 3F-CORR-MID"]}
        ]
        assert Site.objects.get(pk=site.pk).map_version == 1
        servers.poll(
            lambda: status_of(code) == "completed",
            timeout=150,
            interval=0.2,
            what="the delivery completed on the map it was planned on",
        )
        servers.poll(fleet.all_idle_at_dock, timeout=90, interval=0.2, what="the robot home")

        published = maps.publish(without_the_corridor_middle(live), "corridor works")
        assert published.status_code == 201, published.text
        rolled = maps.restore(1)
        assert rolled.status_code == 201, rolled.text
        site.refresh_from_db()
        assert site.map_version == 3
        assert "3F-CORR-MID" in site_map(site).waypoints
        assert "3F-CORR-MID-2" not in site_map(site).waypoints
        assert fleet.errors == []
        assert all(loop.refused == 0 for loop in fleet.loops)
    finally:
        fleet.stop()


def test_a_map_cutting_a_driving_robots_route_replans_it_onto_the_new_map(stack, site, staff):
    maps = MapApi(stack.http_url, staff.api_token_plain)
    live = maps.draft()["document"]
    source = HttpMapSource(stack.http_url, staff.api_token_plain, "tiny")
    fleet = fleet_of(stack, site, live, map_source=source)
    fleet.start()
    try:
        code = order(stack, staff, "1F-PHARM", "3F-WARD")
        servers.poll(
            lambda: status_of(code) == "picked_up",
            timeout=90,
            interval=0.1,
            what="the robot on its way to the ward",
        )

        def published():
            # Refused only while the robot drives to the waypoint removed (a moment at most).
            response = maps.publish(without_the_corridor_middle(live), "corridor works", "replan")
            assert response.status_code in (201, 409), response.text
            return response if response.status_code == 201 else None

        version = servers.poll(published, timeout=30, interval=0.2, what="the map published")

        assert version.json()["replanned"] == ["R1"]
        servers.poll(
            lambda: status_of(code) == "completed",
            timeout=150,
            interval=0.2,
            what="the delivery completed on the new map",
        )
        robot = fleet.robots[0]
        assert robot.map_version == 2
        assert "3F-CORR-MID-2" in robot.map.waypoints
        assert fleet.errors == []
        assert all(loop.refused == 0 for loop in fleet.loops)
    finally:
        fleet.stop()
