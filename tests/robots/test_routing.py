"""Routing on a SiteMap: travel times, legs (path, via, resources) and their memoization."""

import copy
import math
from pathlib import Path

import pytest

from robots import router as graph
from robots.mapcache import router_for
from robots.models import Site
from robots.router import Router, site_map_from_file
from robots.sitefile import site_file_read, site_load

EULJI = Path(__file__).resolve().parents[2] / "sites" / "eulji.yaml"

# Speed 2 m/s. 1F: A -30- B -40- C, and a one-way shortcut C -> A of 20 m; the lift lobby E1
# is 10 m from A; X is an island. 3F: E3 -10- DW -4- DE -6- S, DW-DE guarded by DOOR.
# The lift L costs 20 s + 2 s per floor: 24 s between 1F and 3F.
SMALL = {
    "site": "small",
    "robot_speed": 2.0,
    "floors": [
        {
            "code": "1F",
            "level": 1,
            "waypoints": [
                {"code": "A", "x": 0, "y": 0, "kind": "dock"},
                {"code": "B", "x": 30, "y": 0},
                {"code": "C", "x": 30, "y": 40, "kind": "station"},
                {"code": "E1", "x": 0, "y": 10, "kind": "resource_wait"},
                {"code": "X", "x": 100, "y": 100},
            ],
            "edges": [
                ["A", "B"],
                ["B", "C"],
                {"from": "C", "to": "A", "length": 20, "oneway": True},
                ["A", "E1"],
            ],
        },
        {
            "code": "3F",
            "level": 3,
            "waypoints": [
                {"code": "E3", "x": 0, "y": 0, "kind": "resource_wait"},
                {"code": "DW", "x": 10, "y": 0, "kind": "resource_wait"},
                {"code": "DE", "x": 14, "y": 0, "kind": "resource_wait"},
                {"code": "S", "x": 20, "y": 0, "kind": "station"},
            ],
            "edges": [["E3", "DW"], ["DW", "DE"], ["DE", "S"]],
        },
    ],
    "resources": [
        {
            "code": "L",
            "kind": "elevator",
            "stops": {"1F": "E1", "3F": "E3"},
            "seconds_per_floor": 2,
            "overhead_seconds": 20,
        },
        {"code": "DOOR", "kind": "door", "waiting": ["DW", "DE"], "guards": [["DE", "DW"]]},
    ],
}
SMALL_CODES = [wp["code"] for floor in SMALL["floors"] for wp in floor["waypoints"]]


@pytest.fixture
def router():
    return Router(site_map_from_file(copy.deepcopy(SMALL)))


@pytest.fixture(scope="module")
def eulji_router():
    return Router(site_map_from_file(site_file_read(EULJI)))


@pytest.mark.parametrize(
    ("a", "b", "seconds"),
    [
        ("A", "A", 0.0),
        ("A", "B", 15.0),
        ("A", "C", 35.0),  # the shortcut C -> A is one-way
        ("C", "A", 10.0),
        ("A", "S", 5.0 + 24.0 + 10.0),
        ("S", "C", 10.0 + 24.0 + 5.0 + 35.0),
        ("C", "S", 10.0 + 5.0 + 24.0 + 10.0),
        ("E1", "E3", 24.0),
    ],
)
def test_it_computes_travel_times_by_hand(router, a, b, seconds):
    assert router.travel_time(a, b) == pytest.approx(seconds)


def test_it_reports_unreachable_as_infinity(router):
    assert router.travel_time("A", "X") == math.inf
    assert router.travel_time("X", "A") == math.inf
    assert router.leg("A", "X") == graph.Leg(seconds=math.inf, path=[], via=[], resources=[])


def test_it_rejects_unknown_waypoints(router):
    with pytest.raises(KeyError, match="NOPE"):
        router.travel_time("A", "NOPE")
    with pytest.raises(KeyError, match="NOPE"):
        router.leg("NOPE", "A")


def test_it_gives_a_multi_floor_leg_its_elevator_waypoints_and_resources(router):
    leg = router.leg("C", "S")

    assert leg.seconds == pytest.approx(49.0)
    assert leg.path == ["C", "A", "E1", "E3", "DW", "DE", "S"]
    assert leg.via == ["E1", "E3"]
    assert leg.resources == ["L", "DOOR"]


def test_it_gives_a_single_floor_leg_no_via(router):
    leg = router.leg("A", "C")

    assert leg.path == ["A", "B", "C"]
    assert leg.via == []
    assert leg.resources == []


def test_it_makes_a_leg_to_the_same_waypoint_empty(router):
    assert router.leg("S", "S") == graph.Leg(seconds=0.0, path=["S"], via=[], resources=[])


def test_it_searches_each_source_once(router, monkeypatch):
    searches = []
    real = graph.shortest_paths

    def counting(links, source):
        searches.append(source)
        return real(links, source)

    monkeypatch.setattr(graph, "shortest_paths", counting)
    for target in ["A", "B", "C", "S", "X", "E3"]:
        router.travel_time("A", target)
        router.leg("A", target)
    router.travel_time("C", "S")

    assert searches == ["A", "C"]


def test_it_routes_the_papers_trip_at_eulji(eulji_router):
    to_ward = eulji_router.leg("15F-DOCK-1", "6F-WARD-A")
    to_lab = eulji_router.leg("6F-WARD-A", "2F-LAB-DROP")
    home = eulji_router.leg("2F-LAB-DROP", "15F-DOCK-1")

    base_to_lobby = math.hypot(6, 6) + 8 + 30 + 8  # dock, base, east hall, hall, lobby
    lobby_to_ward_6a = 8 + 28 + math.hypot(4, 8)
    lobby_to_lab_drop = 8 + 28 + 6 + 4 + 8 + math.hypot(8, 4)  # through the lab door
    assert to_ward.seconds == pytest.approx((base_to_lobby + lobby_to_ward_6a) / 0.8 + 30 + 2.5 * 9)
    assert to_ward.path == [
        "15F-DOCK-1",
        "15F-BASE",
        "15F-HALL-E",
        "15F-HALL",
        "15F-ELEV-A-WAIT",
        "6F-ELEV-A-WAIT",
        "6F-HALL",
        "6F-HALL-W",
        "6F-WARD-A",
    ]
    assert to_ward.via == ["15F-ELEV-A-WAIT", "6F-ELEV-A-WAIT"]
    assert to_ward.resources == ["ELEV-A"]
    assert to_lab.seconds == pytest.approx(
        (lobby_to_ward_6a + lobby_to_lab_drop) / 0.8 + 30 + 2.5 * 4
    )
    assert to_lab.via == ["6F-ELEV-A-WAIT", "2F-ELEV-A-WAIT"]
    assert to_lab.resources == ["ELEV-A", "DOOR-2F-LAB"]
    assert home.seconds == pytest.approx((lobby_to_lab_drop + base_to_lobby) / 0.8 + 30 + 2.5 * 13)
    assert home.via == ["2F-ELEV-A-WAIT", "15F-ELEV-A-WAIT"]
    assert home.resources == ["DOOR-2F-LAB", "ELEV-A"]


def test_it_takes_the_narrow_corridor_once_to_ward_6b(eulji_router):
    leg = eulji_router.leg("6F-ELEV-A-WAIT", "6F-WARD-B")

    assert leg.path[2:] == ["6F-CORR-W", "6F-CORR-MID", "6F-CORR-E", "6F-WARD-B"]
    assert leg.resources == ["CORR-6F"]


def test_it_reaches_every_station_and_dock_of_eulji_from_every_other(eulji_router):
    places = eulji_router.site_map.codes_of_kind("station", "dock")

    assert len(places) == 33
    assert all(eulji_router.travel_time(a, b) < math.inf for a in places for b in places)


def test_it_routes_the_same_from_the_database_as_from_the_file(db):
    site = site_load(data=copy.deepcopy(SMALL))
    from_file = Router(site_map_from_file(SMALL))
    from_db = router_for(site)

    for a in SMALL_CODES:
        for b in SMALL_CODES:
            assert from_db.travel_time(a, b) == pytest.approx(from_file.travel_time(a, b))
            assert from_db.leg(a, b).resources == from_file.leg(a, b).resources
    assert from_db.leg("C", "S").via == ["E1", "E3"]


def test_it_shares_one_router_per_map_version(db):
    site = site_load(data=copy.deepcopy(SMALL))
    first = router_for(site)

    assert router_for(Site.objects.get(pk=site.pk)) is first
    reloaded = site_load(data=copy.deepcopy(SMALL))
    assert reloaded.map_version == site.map_version + 1
    assert router_for(reloaded) is not first
    assert router_for(reloaded).site_map.map_version == reloaded.map_version
