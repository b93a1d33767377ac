"""The site file loader: validation of the whole file, upserts by code, and the command."""

import copy
import io
import json
from pathlib import Path

import pytest
from django.core.management import CommandError, call_command

from robots.models import Edge, Floor, Resource, ResourceWaypoint, Robot, Site, Waypoint
from robots.sitefile import SiteFileInvalid, site_file_read, site_file_validate, site_load

ROOT = Path(__file__).resolve().parents[2]
EULJI = ROOT / "sites" / "eulji.yaml"
BROKEN = Path(__file__).resolve().parent / "data" / "broken_site.yaml"

BROKEN_PROBLEMS = [
    "robot_sped: unknown key (did you mean 'robot_speed'?)",
    "ack_timeout: must be > 0, not 0",
    "floors[8].waypoints[2].code: duplicate code '7F-HALL' (also floors[8].waypoints[1])",
    "floors[10].waypoints[5].knd: unknown key (did you mean 'kind'?)",
    "floors[15].level: duplicate level 2 (also floors[13])",
    "floors[15].waypoints: a floor needs at least one waypoint",
    "floors[6].edges[1]: unknown waypoint '9F-HALL-WEST'",
    "floors[11].edges[5]: waypoint '3F-HALL' is on floor '3F', not '4F'; "
    "floors connect only through elevators",
    "floors[12].edges[1].length: must be >= 0, not -28",
    "resources[0].stops: floor '16F' does not exist",
    "resources[1].guards[0]: '2F-LAB-DOOR-S' - '2F-LAB-HALL' is not an edge of the file",
    "resources[2].capacity: must be >= 1, not 0",
    "robots[2].dock: '15F-HALL' is a plain waypoint, not a dock",
    "robots[3].dock: unknown waypoint '15F-DOCK-5'",
    "robots[4].capacity: must be >= 1, not 0",
    "robots[4].code: duplicate robot code 'R2' (also robots[1])",
    "floors[4].waypoints[5]: station '11F-WARD-B' is unreachable: no route to or from '15F-DOCK-1'",
    "floors[5].waypoints[4]: station '10F-WARD-A' is unreachable: "
    "no route from it back to '15F-DOCK-1'",
    "floors[6].waypoints[4]: station '9F-WARD-A' is unreachable: no route to or from '15F-DOCK-1'",
]


def eulji() -> dict:
    return site_file_read(EULJI)


def rows() -> dict[str, list[tuple]]:
    """Every map and robot row with the fields the loader writes, to compare before/after."""
    return {
        "sites": sorted(Site.objects.values_list("pk", "code", "name", "robot_speed")),
        "floors": sorted(Floor.objects.values_list("pk", "code", "level", "name")),
        "waypoints": sorted(
            Waypoint.objects.values_list("pk", "floor_id", "code", "name", "kind", "x", "y")
        ),
        "edges": sorted(
            Edge.objects.values_list(
                "pk", "source_id", "target_id", "length", "oneway", "guarded_by_id"
            )
        ),
        "resources": sorted(
            Resource.objects.values_list(
                "pk", "code", "kind", "capacity", "seconds_per_floor", "overhead_seconds"
            )
        ),
        "stops": sorted(ResourceWaypoint.objects.values_list("pk", "resource_id", "waypoint_id")),
        "robots": sorted(Robot.objects.values_list("pk", "code", "site_id", "dock_id", "capacity")),
    }


def mini_site() -> dict:
    """Two floors joined by an elevator; a door in front of the 2F lab; one robot."""
    return {
        "site": "mini",
        "floors": [
            {
                "code": "1F",
                "level": 1,
                "waypoints": [
                    {"code": "1F-DOCK", "x": 0, "y": 0, "kind": "dock"},
                    {"code": "1F-HALL", "x": 10, "y": 0},
                    {"code": "1F-ELEV", "x": 20, "y": 0, "kind": "resource_wait"},
                ],
                "edges": [["1F-DOCK", "1F-HALL"], ["1F-HALL", "1F-ELEV"]],
            },
            {
                "code": "2F",
                "level": 2,
                "waypoints": [
                    {"code": "2F-ELEV", "x": 20, "y": 0, "kind": "resource_wait"},
                    {"code": "2F-DOOR-A", "x": 20, "y": 5, "kind": "resource_wait"},
                    {"code": "2F-DOOR-B", "x": 20, "y": 7, "kind": "resource_wait"},
                    {"code": "2F-LAB", "x": 20, "y": 20, "kind": "station", "name": "Lab"},
                ],
                "edges": [
                    ["2F-ELEV", "2F-DOOR-A"],
                    ["2F-DOOR-A", "2F-DOOR-B"],
                    ["2F-DOOR-B", "2F-LAB"],
                ],
            },
        ],
        "resources": [
            {
                "code": "ELEV",
                "kind": "elevator",
                "stops": {"1F": "1F-ELEV", "2F": "2F-ELEV"},
                "seconds_per_floor": 2,
                "overhead_seconds": 20,
            },
            {
                "code": "DOOR",
                "kind": "door",
                "waiting": ["2F-DOOR-A", "2F-DOOR-B"],
                "guards": [["2F-DOOR-A", "2F-DOOR-B"]],
            },
        ],
        "robots": [{"code": "R1", "dock": "1F-DOCK"}],
    }


def _walk(data, path):
    for step in path[:-1]:
        data = data[step]
    return data, path[-1]


def put(*path, value):
    def change(data):
        parent, last = _walk(data, path)
        parent[last] = value

    return change


def drop(*path):
    def change(data):
        parent, last = _walk(data, path)
        del parent[last]

    return change


def add(*path, item):
    def change(data):
        parent, last = _walk(data, path)
        parent[last].append(item)

    return change


RULES = {
    "missing key": (drop("floors", 0, "level"), "floors[0].level: required"),
    "wrong type": (
        put("floors", 0, "waypoints", 1, "x", value="ten"),
        "floors[0].waypoints[1].x: must be a number, not a string 'ten'",
    ),
    "boolean as number": (
        put("grant_timeout", value=True),
        "grant_timeout: must be a number, not a boolean True",
    ),
    "unknown top-level key": (
        put("robot_sped", value=1),
        "robot_sped: unknown key (did you mean 'robot_speed'?)",
    ),
    "unknown item key": (
        put("floors", 1, "waypoints", 3, "nmae", value="Lab"),
        "floors[1].waypoints[3].nmae: unknown key (did you mean 'name'?)",
    ),
    "item not a mapping": (
        put("floors", 1, value="2F"),
        "floors[1]: must be a mapping, not a string",
    ),
    "site code not a slug": (put("site", value="my site"), "site: 'my site' is not a valid code"),
    "zero speed": (put("robot_speed", value=0), "robot_speed: must be > 0, not 0"),
    "negative timeout": (put("offline_timeout", value=-5), "offline_timeout: must be > 0, not -5"),
    "battery threshold above 1": (
        put("battery_threshold", value=1.5),
        "battery_threshold: must be <= 1, not 1.5",
    ),
    "zero due time": (put("stat_due_minutes", value=0), "stat_due_minutes: must be > 0, not 0"),
    "due time not a number": (
        put("routine_due_minutes", value="2h"),
        "routine_due_minutes: must be a number, not a string '2h'",
    ),
    "negative dwell": (
        put("stop_dwell_seconds", value=-1),
        "stop_dwell_seconds: must be >= 0, not -1",
    ),
    "no floors": (put("floors", value=[]), "floors: a site needs at least one floor"),
    "duplicate waypoint code across floors": (
        add("floors", 1, "waypoints", item={"code": "1F-HALL", "x": 0, "y": 0}),
        "floors[1].waypoints[4].code: duplicate code '1F-HALL' (also floors[0].waypoints[1])",
    ),
    "resource code equal to a floor code": (
        put("resources", 1, "code", value="2F"),
        "resources[1].code: duplicate code '2F' (also floors[1])",
    ),
    "floor without waypoints": (
        add("floors", item={"code": "3F", "level": 3, "waypoints": []}),
        "floors[2].waypoints: a floor needs at least one waypoint",
    ),
    "duplicate floor level": (
        put("floors", 1, "level", value=1),
        "floors[1].level: duplicate level 1 (also floors[0])",
    ),
    "unknown waypoint kind": (
        put("floors", 0, "waypoints", 1, "kind", value="hallway"),
        "floors[0].waypoints[1].kind: unknown kind 'hallway' "
        "(expected one of plain, station, dock, resource_wait, refuge)",
    ),
    "edge to an unknown waypoint": (
        add("floors", 0, "edges", item=["1F-HALL", "1F-NOWHERE"]),
        "floors[0].edges[2]: unknown waypoint '1F-NOWHERE'",
    ),
    "edge between floors": (
        add("floors", 0, "edges", item=["1F-HALL", "2F-LAB"]),
        "floors[0].edges[2]: waypoint '2F-LAB' is on floor '2F', not '1F'; "
        "floors connect only through elevators",
    ),
    "duplicate edge the other way round": (
        add("floors", 0, "edges", item=["1F-HALL", "1F-DOCK"]),
        "floors[0].edges[2]: duplicate edge '1F-HALL' - '1F-DOCK' (also floors[0].edges[0])",
    ),
    "edge to itself": (
        add("floors", 0, "edges", item=["1F-HALL", "1F-HALL"]),
        "floors[0].edges[2]: an edge from '1F-HALL' to itself",
    ),
    "edge of one end": (
        add("floors", 0, "edges", item=["1F-HALL"]),
        "floors[0].edges[2]: an edge is [A, B] or {from, to, length, oneway}",
    ),
    "negative edge length": (
        put("floors", 0, "edges", 0, value={"from": "1F-DOCK", "to": "1F-HALL", "length": -1}),
        "floors[0].edges[0].length: must be >= 0, not -1",
    ),
    "unknown resource kind": (
        put("resources", 1, "kind", value="gate"),
        "resources[1].kind: unknown kind 'gate' (expected one of elevator, door, corridor)",
    ),
    "resource capacity below 1": (
        put("resources", 1, "capacity", value=0),
        "resources[1].capacity: must be >= 1, not 0",
    ),
    "elevator stop on a missing floor": (
        put("resources", 0, "stops", "9F", value="2F-LAB"),
        "resources[0].stops: floor '9F' does not exist",
    ),
    "elevator stop on another floor": (
        put("resources", 0, "stops", "2F", value="1F-HALL"),
        "resources[0].stops: waypoint '1F-HALL' is on floor '1F', not '2F'",
    ),
    "elevator stop unknown": (
        put("resources", 0, "stops", "2F", value="2F-NOPE"),
        "resources[0].stops: unknown waypoint '2F-NOPE' (stop on floor '2F')",
    ),
    "elevator with one stop": (
        put("resources", 0, "stops", value={"1F": "1F-ELEV"}),
        "resources[0].stops: an elevator needs at least 2 stops",
    ),
    "elevator without seconds per floor": (
        drop("resources", 0, "seconds_per_floor"),
        "resources[0].seconds_per_floor: required for an elevator",
    ),
    "elevator without overhead": (
        drop("resources", 0, "overhead_seconds"),
        "resources[0].overhead_seconds: required for an elevator",
    ),
    "elevator with zero seconds per floor": (
        put("resources", 0, "seconds_per_floor", value=0),
        "resources[0].seconds_per_floor: must be > 0, not 0",
    ),
    "elevator with waiting waypoints": (
        put("resources", 0, "waiting", value=["1F-ELEV"]),
        "resources[0].waiting: an elevator has no 'waiting'",
    ),
    "door with stops": (
        put("resources", 1, "stops", value={"2F": "2F-DOOR-A"}),
        "resources[1].stops: a door has no 'stops'",
    ),
    "door without waiting key": (
        drop("resources", 1, "waiting"),
        "resources[1].waiting: required for a door",
    ),
    "door without waiting waypoints": (
        put("resources", 1, "waiting", value=[]),
        "resources[1].waiting: a door needs at least one waiting waypoint",
    ),
    "door waiting at an unknown waypoint": (
        put("resources", 1, "waiting", 1, value="2F-NOPE"),
        "resources[1].waiting[1]: unknown waypoint '2F-NOPE'",
    ),
    "door guarding nothing": (
        put("resources", 1, "guards", value=[]),
        "resources[1].guards: a door needs at least one guarded edge",
    ),
    "guard that is not an edge": (
        put("resources", 1, "guards", value=[["2F-DOOR-A", "2F-LAB"]]),
        "resources[1].guards[0]: '2F-DOOR-A' - '2F-LAB' is not an edge of the file",
    ),
    "guard against a one-way edge": (
        put(
            "floors",
            1,
            "edges",
            1,
            value={"from": "2F-DOOR-B", "to": "2F-DOOR-A", "oneway": True},
        ),
        "resources[1].guards[0]: '2F-DOOR-A' - '2F-DOOR-B' is not an edge of the file",
    ),
    "edge guarded twice": (
        add(
            "resources",
            item={
                "code": "CORR",
                "kind": "corridor",
                "waiting": ["2F-DOOR-A"],
                "guards": [["2F-DOOR-B", "2F-DOOR-A"]],
            },
        ),
        "resources[2].guards[0]: '2F-DOOR-B' - '2F-DOOR-A' is already guarded by 'DOOR'",
    ),
    "resource_wait no resource waits at": (
        put("floors", 0, "waypoints", 1, "kind", value="resource_wait"),
        "floors[0].waypoints[1]: '1F-HALL' is of kind resource_wait but no resource waits "
        "there (list it in a resource's stops or waiting, or make it plain)",
    ),
    "robot dock unknown": (
        put("robots", 0, "dock", value="1F-NOPE"),
        "robots[0].dock: unknown waypoint '1F-NOPE'",
    ),
    "robot dock not a dock": (
        put("robots", 0, "dock", value="1F-HALL"),
        "robots[0].dock: '1F-HALL' is a plain waypoint, not a dock",
    ),
    "robot capacity below 1": (
        put("robots", 0, "capacity", value=0),
        "robots[0].capacity: must be >= 1, not 0",
    ),
    "robot code with a space": (
        put("robots", 0, "code", value="R 1"),
        "robots[0].code: 'R 1' is not a valid code",
    ),
    "duplicate robot codes": (
        add("robots", item={"code": "R1", "dock": "1F-DOCK"}),
        "robots[1].code: duplicate robot code 'R1' (also robots[0])",
    ),
    "station cut off": (
        drop("floors", 1, "edges", 2),
        "floors[1].waypoints[3]: station '2F-LAB' is unreachable: no route to or from '1F-DOCK'",
    ),
    "station with no way back": (
        put("floors", 1, "edges", 2, value={"from": "2F-DOOR-B", "to": "2F-LAB", "oneway": True}),
        "floors[1].waypoints[3]: station '2F-LAB' is unreachable: "
        "no route from it back to '1F-DOCK'",
    ),
}


def test_it_finds_nothing_wrong_with_the_mini_site():
    assert site_file_validate(mini_site()) == []


@pytest.mark.parametrize(("change", "problem"), RULES.values(), ids=RULES.keys())
def test_it_reports_each_rule(change, problem):
    data = mini_site()
    change(data)

    assert problem in site_file_validate(data)


def test_it_reports_every_problem_not_just_the_first():
    chosen = [
        "wrong type",
        "zero speed",
        "duplicate floor level",
        "edge to an unknown waypoint",
        "elevator stop on a missing floor",
        "guard that is not an edge",
        "robot dock not a dock",
    ]
    data = mini_site()
    for name in chosen:
        RULES[name][0](data)

    problems = site_file_validate(data)

    assert [RULES[name][1] for name in chosen if RULES[name][1] not in problems] == []


def test_it_reports_a_dock_robots_cannot_leave():
    data = mini_site()
    data["floors"][0]["waypoints"].append(
        {"code": "1F-PHARM", "x": 10, "y": 10, "kind": "station", "name": "Pharmacy"}
    )
    data["floors"][0]["edges"] = [
        {"from": "1F-HALL", "to": "1F-DOCK", "oneway": True},
        ["1F-HALL", "1F-ELEV"],
        ["1F-HALL", "1F-PHARM"],
    ]

    assert site_file_validate(data) == [
        "floors[0].waypoints[0]: dock '1F-DOCK' is unreachable: no route from it back to '1F-PHARM'"
    ]


def test_it_accepts_a_one_way_loop():
    data = mini_site()
    data["floors"][0]["edges"] = [
        {"from": "1F-DOCK", "to": "1F-HALL", "oneway": True},
        {"from": "1F-HALL", "to": "1F-ELEV", "oneway": True},
        {"from": "1F-ELEV", "to": "1F-DOCK", "oneway": True},
    ]

    assert site_file_validate(data) == []


def test_it_finds_nothing_wrong_with_the_demo_site():
    assert site_file_validate(eulji()) == []


def test_it_reports_every_problem_of_the_broken_file():
    assert sorted(site_file_validate(site_file_read(BROKEN))) == sorted(BROKEN_PROBLEMS)


def test_it_writes_nothing_for_the_broken_file(db):
    with pytest.raises(SiteFileInvalid) as raised:
        site_load(data=site_file_read(BROKEN))

    assert sorted(raised.value.problems) == sorted(BROKEN_PROBLEMS)
    assert all(not found for found in rows().values())


def test_it_leaves_a_loaded_site_alone_when_its_broken_file_comes(db):
    site_load(data=eulji())
    before = rows()

    with pytest.raises(SiteFileInvalid):
        site_load(data=site_file_read(BROKEN))

    assert rows() == before
    assert Site.objects.get(code="eulji").map_version == 1


def test_it_loads_the_demo_site(db):
    site = site_load(data=eulji())

    site.refresh_from_db()
    assert (site.code, site.name) == ("eulji", "Eulji University Hospital (Daejeon)")
    assert (site.robot_speed, site.ack_timeout, site.map_version) == (0.8, 30.0, 1)
    assert site.loaded_at is not None
    due = (site.stat_due_minutes, site.urgent_due_minutes, site.routine_due_minutes)
    assert (due, site.stop_dwell_seconds) == ((20, 45, 120), 30)
    assert site.floors.count() == 15
    assert set(site.floors.values_list("level", flat=True)) == set(range(1, 16))
    assert site.waypoints.count() == 102
    assert site.waypoints.filter(kind="station").count() == 29
    assert site.edges.count() == 87
    assert dict(site.resources.values_list("code", "kind")) == {
        "ELEV-A": "elevator",
        "DOOR-2F-LAB": "door",
        "CORR-6F": "corridor",
    }
    elevator = site.resources.get(code="ELEV-A")
    assert (elevator.seconds_per_floor, elevator.overhead_seconds) == (2.5, 30.0)
    assert elevator.stops.count() == 15
    assert set(
        site.edges.filter(guarded_by__isnull=False).values_list(
            "guarded_by__code", "source__code", "target__code"
        )
    ) == {
        ("DOOR-2F-LAB", "2F-LAB-DOOR-S", "2F-LAB-DOOR-N"),
        ("CORR-6F", "6F-CORR-W", "6F-CORR-MID"),
        ("CORR-6F", "6F-CORR-MID", "6F-CORR-E"),
    }
    assert list(site.robots.values_list("code", "dock__code", "capacity")) == [
        (f"R{n}", f"15F-DOCK-{n}", 4) for n in range(1, 5)
    ]
    ward = site.waypoints.get(code="6F-WARD-A")
    assert (ward.name, ward.floor.code, ward.kind) == ("Ward 6A nursing station", "6F", "station")


def test_it_loads_twice_into_the_same_rows(db):
    first = site_load(data=eulji())
    before = rows()

    second = site_load(data=eulji())

    assert second.pk == first.pk
    assert rows() == before
    assert second.map_version == first.map_version + 1 == 2
    assert second.loaded_at >= first.loaded_at


def test_it_updates_an_edge_in_place(db):
    site = site_load(data=eulji())
    edge = Edge.objects.get(site=site, source__code="6F-HALL", target__code="6F-HALL-W")
    data = eulji()
    edges = data["floors"][9]["edges"]
    edges[edges.index(["6F-HALL", "6F-HALL-W"])] = {
        "from": "6F-HALL",
        "to": "6F-HALL-W",
        "length": 35.5,
    }

    site_load(data=data)

    updated = Edge.objects.get(pk=edge.pk)
    assert (edge.length, updated.length) == (28.0, 35.5)
    assert Edge.objects.filter(site=site).count() == 87


def test_it_deletes_what_the_file_no_longer_has(db):
    site_load(data=eulji())
    kept = Waypoint.objects.get(code="2F-LAB-DROP").pk
    data = eulji()
    second_floor = data["floors"][13]
    second_floor["waypoints"] = [
        wp for wp in second_floor["waypoints"] if wp["code"] != "2F-LAB-PICKUP"
    ]
    second_floor["edges"].remove(["2F-LAB-HALL", "2F-LAB-PICKUP"])
    data["resources"] = [r for r in data["resources"] if r["code"] != "CORR-6F"]
    data["floors"][9]["waypoints"][4]["kind"] = "plain"  # 6F-CORR-W waits for nothing now
    data["floors"][9]["waypoints"][6]["kind"] = "plain"  # 6F-CORR-E

    site_load(data=data)

    assert not Waypoint.objects.filter(code="2F-LAB-PICKUP").exists()
    assert not Edge.objects.filter(target__code="2F-LAB-PICKUP").exists()
    assert not Resource.objects.filter(code="CORR-6F").exists()
    assert (
        not Edge.objects.filter(guarded_by__isnull=False)
        .exclude(guarded_by__code="DOOR-2F-LAB")
        .exists()
    )
    assert Waypoint.objects.get(code="2F-LAB-DROP").pk == kept
    assert Waypoint.objects.count() == 101


def test_it_keeps_robot_tokens_and_reported_state(db):
    site_load(data=eulji())
    Robot.objects.filter(code="R2").update(token_hash="a" * 64, battery=0.5, status="charging")
    data = eulji()
    data["robots"][1] = {"code": "R2", "dock": "15F-DOCK-1", "capacity": 2, "name": "Robbie"}

    site_load(data=data)

    robot = Robot.objects.get(code="R2")
    assert (robot.dock.code, robot.capacity, robot.name) == ("15F-DOCK-1", 2, "Robbie")
    assert (robot.token_hash, robot.battery, robot.status) == ("a" * 64, 0.5, "charging")


def test_it_refuses_to_drop_the_dock_of_a_robot_not_in_the_file(db):
    site_load(data=eulji())
    data = eulji()
    data["robots"] = data["robots"][:3]  # R4 stays in the database, docked at 15F-DOCK-4
    base = data["floors"][0]
    base["waypoints"] = [wp for wp in base["waypoints"] if wp["code"] != "15F-DOCK-4"]
    base["edges"].remove(["15F-BASE", "15F-DOCK-4"])
    before = rows()

    with pytest.raises(SiteFileInvalid) as raised:
        site_load(data=data)

    assert raised.value.problems == [
        "robots: robot 'R4' (not in the file) docks at '15F-DOCK-4', which the file no "
        "longer has as a dock; list the robot with a new dock"
    ]
    assert rows() == before


def test_it_refuses_a_robot_of_another_site(db):
    site_load(data=mini_site())  # R1 docks at the mini site
    with pytest.raises(SiteFileInvalid) as raised:
        site_load(data=eulji())

    assert raised.value.problems == ["robots[0].code: robot 'R1' belongs to site 'mini'"]
    assert not Site.objects.filter(code="eulji").exists()


def test_it_reads_json_like_yaml(tmp_path):
    as_json = tmp_path / "eulji.json"
    as_json.write_text(json.dumps(eulji()))

    assert site_file_read(as_json) == eulji()


@pytest.mark.parametrize(
    ("name", "text", "problem"),
    [
        ("site.yaml", "site: a\nsite: b\n", "duplicate key 'site'"),
        ("site.json", '{"site": "a", "site": "b"}', "duplicate key(s) 'site'"),
        ("site.yaml", "site: [unclosed\n", "site.yaml: not valid yaml"),
        ("site.yaml", "- just\n- a list\n", "site.yaml: the file must hold a mapping"),
        ("site.txt", "site: a\n", "site.txt: expected a .yaml, .yml or .json file"),
    ],
)
def test_it_refuses_files_it_cannot_read(tmp_path, name, text, problem):
    path = tmp_path / name
    path.write_text(text)

    with pytest.raises(SiteFileInvalid) as raised:
        site_file_read(path)

    assert problem in raised.value.problems[0]


def test_it_loads_through_the_command(db):
    out = io.StringIO()

    call_command("load_site", str(EULJI), stdout=out)
    call_command("load_site", str(EULJI), stdout=out)

    assert out.getvalue().splitlines() == [
        "Created site 'eulji' (map version 1): 15 floors, 102 waypoints (29 stations, 4 docks),"
        " 87 edges, 3 resources, 4 robots",
        "Updated site 'eulji' (map version 2): 15 floors, 102 waypoints (29 stations, 4 docks),"
        " 87 edges, 3 resources, 4 robots",
    ]


def test_it_prints_every_problem_and_fails_through_the_command(db):
    err = io.StringIO()

    with pytest.raises(CommandError, match="19 problem"):
        call_command("load_site", str(BROKEN), stdout=io.StringIO(), stderr=err)

    assert sorted(err.getvalue().splitlines()) == sorted(BROKEN_PROBLEMS)
    assert not Site.objects.exists()


def test_it_only_checks_with_the_check_option(db):
    out = io.StringIO()

    call_command("load_site", str(EULJI), "--check", stdout=out)

    assert out.getvalue().strip() == f"{EULJI}: valid site file for site 'eulji'"
    assert not Site.objects.exists()


def test_it_fails_the_command_on_a_missing_file(db, tmp_path):
    with pytest.raises(CommandError, match="cannot read"):
        call_command("load_site", str(tmp_path / "nowhere.yaml"))


def test_it_loads_the_json_form_through_the_command(db, tmp_path):
    as_json = tmp_path / "mini.json"
    as_json.write_text(json.dumps(mini_site()))

    call_command("load_site", str(as_json), stdout=io.StringIO())

    assert Site.objects.get(code="mini").waypoints.count() == 7


def test_it_does_not_change_the_demo_file_by_loading(db):
    data = eulji()
    pristine = copy.deepcopy(data)

    site_load(data=data)

    assert data == pristine
