"""Map versions: validate, diff, publish, roll back and export (maps/services.py), and the
roll-out to robots holding plans across what a new map removes."""

import copy

import pytest

from maps.choices import Rollout
from maps.diff import map_diff
from maps.documents import document_yaml, site_document
from maps.models import MapVersion
from maps.services import (
    MapBlocked,
    MapInvalid,
    draft_check,
    draft_open,
    draft_publish,
    draft_rollout_set,
    draft_save,
    version_restore,
)
from robots.mapcache import router_for, site_map
from robots.models import Robot, Site
from robots.sitefile import site_file_parse, site_load
from scheduling.models import RobotPlan
from scheduling.services import task_allocate
from tests import factories
from tests.scheduling.conftest import request, robot_ready


def drawn(site: Site):
    """The site's map without its ids and version: what a robot would drive on."""
    current = site_map(Site.objects.get(pk=site.pk))
    waypoints = {
        code: (wp.kind, wp.name, wp.floor, wp.x, wp.y) for code, wp in current.waypoints.items()
    }
    edges = sorted(
        (e.source, e.target, round(e.length, 6), e.oneway, e.guarded_by) for e in current.edges
    )
    resources = {
        code: (r.kind, r.capacity, r.seconds_per_floor, r.overhead_seconds, sorted(r.waypoints))
        for code, r in current.resources.items()
    }
    return current.floors, current.floor_names, waypoints, edges, resources


def with_new_station(document: dict) -> dict:
    """The tiny site with a station on 2F joined to the elevator lobby."""
    document = copy.deepcopy(document)
    floor = next(f for f in document["floors"] if f["code"] == "2F")
    floor["waypoints"].append(
        {"code": "2F-XRAY", "x": 30, "y": 0, "kind": "station", "name": "X-ray"}
    )
    floor["edges"].append(["2F-ELEV-WAIT", "2F-XRAY"])
    return document


def draft_of(site: Site, document: dict, admin, **fields):
    draft = draft_open(site=site)
    return draft_save(site=site, document=document, revision=draft.revision, user=admin, **fields)


def test_it_exports_the_live_map_as_a_site_file_that_loads_to_the_same_map(site, robot):
    before = drawn(site)
    text = document_yaml(site_document(site))

    reloaded = site_load(data=site_file_parse(text, name="tiny.yaml"))

    assert reloaded.map_version == site.map_version + 1
    assert drawn(site) == before
    assert "1F-PHARM" in text
    assert "CORR-3F" in text


def test_it_publishes_a_draft_as_a_new_version_that_exports_and_reloads(site, staff):
    draft = draft_of(site, with_new_station(draft_open(site=site).document), staff)

    version = draft_publish(site=site, revision=draft.revision, user=staff, note="X-ray opens")

    site.refresh_from_db()
    assert (version.number, version.author, version.note) == (2, staff, "X-ray opens")
    assert site.map_version == 2
    assert site_map(site).waypoints["2F-XRAY"].kind == "station"
    assert router_for(site).leg("1F-PHARM", "2F-XRAY").path[-1] == "2F-XRAY"
    baseline = MapVersion.objects.get(site=site, number=1)  # the file load_site read, kept
    assert baseline.author is None
    assert "2F-XRAY" not in str(baseline.document)
    published = drawn(site)
    site_load(data=site_file_parse(document_yaml(version.document), name="v2.yaml"))
    assert drawn(site) == published


def test_it_refuses_a_draft_naming_every_problem_and_leaves_the_live_map(site, staff):
    document = with_new_station(draft_open(site=site).document)
    floor = document["floors"][1]
    floor["edges"].append(["2F-XRAY", "2F-NOWHERE"])  # dangling
    floor["waypoints"].append({"code": "1F-PHARM", "x": 1, "y": 1})  # duplicated code
    draft = draft_of(site, document, staff)
    before = drawn(site)

    with pytest.raises(MapInvalid) as refused:
        draft_publish(site=site, revision=draft.revision, user=staff)

    problems = refused.value.problems
    assert any("unknown waypoint '2F-NOWHERE'" in p and "edges[4]" in p for p in problems)
    assert any("duplicate code '1F-PHARM'" in p for p in problems)
    site.refresh_from_db()
    assert site.map_version == 1
    assert drawn(site) == before
    assert draft_check(site=site).problems == problems


def test_it_lists_what_a_draft_changes_against_the_live_map(site):
    live = site_document(site)
    draft = with_new_station(live)
    floor1 = next(f for f in draft["floors"] if f["code"] == "1F")
    hall = next(wp for wp in floor1["waypoints"] if wp["code"] == "1F-HALL")
    hall["x"] = 11
    pharmacy = next(wp for wp in floor1["waypoints"] if wp["code"] == "1F-PHARM")
    pharmacy["name"] = "Central pharmacy"
    draft["resources"] = [r for r in draft["resources"] if r["code"] != "CORR-3F"]

    changes = {(c.what, c.how, c.code) for c in map_diff(live, draft).changes}

    assert {
        ("waypoint", "added", "2F-XRAY"),
        ("station", "added", "2F-XRAY"),
        ("edge", "added", "2F-ELEV-WAIT – 2F-XRAY"),
        ("waypoint", "moved", "1F-HALL"),
        ("waypoint", "renamed", "1F-PHARM"),
        ("resource", "removed", "CORR-3F"),
    } <= changes
    assert map_diff(live, live).is_empty


def test_it_rolls_back_to_an_older_version_as_a_new_one(site, staff):
    original = drawn(site)
    draft = draft_of(site, with_new_station(draft_open(site=site).document), staff)
    draft_publish(site=site, revision=draft.revision, user=staff)

    version = version_restore(site=site, number=1, user=staff)

    assert (version.number, version.restored_from, version.note) == (3, 1, "rollback to version 1")
    assert drawn(site) == original
    assert [v.number for v in MapVersion.objects.filter(site=site)] == [3, 2, 1]


# --- Roll-out to a running fleet (PostgreSQL: robot rows locked as in production) --------------


def without_the_1f_hall(document: dict) -> dict:
    """1F's hall replaced by one further south: every route from the docks changes."""
    document = copy.deepcopy(document)
    floor = next(f for f in document["floors"] if f["code"] == "1F")
    floor["waypoints"] = [wp for wp in floor["waypoints"] if wp["code"] != "1F-HALL"]
    floor["waypoints"].append({"code": "1F-HALL-S", "x": 10, "y": -4})
    floor["edges"] = [
        [a.replace("1F-HALL", "1F-HALL-S"), b.replace("1F-HALL", "1F-HALL-S")]
        for a, b in floor["edges"]
    ]
    return document


@pytest.fixture
def robot_on_its_way(site, robot):
    """R1 at its dock with a delivery from the pharmacy: its route crosses 1F-HALL."""
    robot_ready(robot)
    task = request(site)
    assert task_allocate(task_id=task.pk)
    return robot


@pytest.mark.django_db(transaction=True)
def test_it_refuses_a_map_that_cuts_a_robots_route_when_the_site_chooses_to(
    site, robot_on_its_way, staff
):
    plan = RobotPlan.objects.get(robot=robot_on_its_way)
    draft = draft_of(site, without_the_1f_hall(site_document(site)), staff)
    assert draft.rollout == Rollout.REFUSE
    check = draft_check(site=site)
    assert [(c.robot, c.crosses) for c in check.impact.cut] == [("R1", ("waypoint 1F-HALL",))]

    with pytest.raises(MapBlocked) as refused:
        draft_publish(site=site, revision=draft.revision, user=staff)

    assert refused.value.impact.wire()["routes"] == [
        {"robot": "R1", "crosses": ["waypoint 1F-HALL"]}
    ]
    site.refresh_from_db()
    assert site.map_version == 1
    assert "1F-HALL" in site_map(site).waypoints
    assert RobotPlan.objects.get(robot=robot_on_its_way).version == plan.version


@pytest.mark.django_db(transaction=True)
def test_it_publishes_and_replans_the_robots_whose_route_it_cuts(site, robot_on_its_way, staff):
    other = factories.robot_create(site, "R2", dock=site.waypoints.get(code="1F-DOCK-2"))
    before = RobotPlan.objects.get(robot=robot_on_its_way)
    draft_rollout_set(site=site, rollout=Rollout.REPLAN, user=staff)
    draft = draft_of(site, without_the_1f_hall(site_document(site)), staff)

    version = draft_publish(site=site, revision=draft.revision, user=staff)

    site.refresh_from_db()
    after = RobotPlan.objects.get(robot=robot_on_its_way)
    assert version.replanned == ["R1"]
    assert site.map_version == 2
    assert after.version == before.version + 1
    assert [s["waypoint"] for s in after.body["stops"]] == ["1F-PHARM", "2F-LAB"]
    robot_on_its_way.refresh_from_db()
    path = router_for(site).leg(robot_on_its_way.dock.code, "1F-PHARM").path
    assert "1F-HALL-S" in path
    assert "1F-HALL" not in path
    assert not RobotPlan.objects.filter(robot=other).exists()  # untouched: nothing to re-plan


@pytest.mark.django_db(transaction=True)
def test_it_refuses_to_remove_a_station_with_a_delivery_pending_whatever_the_site_chose(
    site, robot_on_its_way, staff
):
    lab_removed = site_document(site)
    floor2 = next(f for f in lab_removed["floors"] if f["code"] == "2F")
    floor2["waypoints"] = [wp for wp in floor2["waypoints"] if wp["code"] != "2F-LAB"]
    floor2["edges"] = [e for e in floor2["edges"] if "2F-LAB" not in e]
    draft_rollout_set(site=site, rollout=Rollout.REPLAN, user=staff)
    draft = draft_of(site, lab_removed, staff)

    with pytest.raises(MapBlocked) as refused:
        draft_publish(site=site, revision=draft.revision, user=staff)

    blockers = refused.value.impact.blockers
    assert any("drop-off at 2F-LAB" in b and "T-" in b for b in blockers), blockers
    site.refresh_from_db()
    assert site.map_version == 1


@pytest.mark.django_db(transaction=True)
def test_it_refuses_a_map_removing_the_waypoint_a_robot_is_driving_to_even_to_replan(
    site, robot_on_its_way, staff
):
    Robot.objects.filter(pk=robot_on_its_way.pk).update(status="moving")  # leaving its dock
    draft_rollout_set(site=site, rollout=Rollout.REPLAN, user=staff)
    draft = draft_of(site, without_the_1f_hall(site_document(site)), staff)

    with pytest.raises(MapBlocked) as refused:
        draft_publish(site=site, revision=draft.revision, user=staff)

    assert refused.value.impact.blockers == [
        "robot R1 is on its way to waypoint 1F-HALL, which the new map removes: "
        "publish once it has passed"
    ]
    assert Site.objects.get(pk=site.pk).map_version == 1


def test_it_exports_a_site_in_seven_queries_however_big(site, robot, django_assert_num_queries):
    with django_assert_num_queries(7):
        site_document(site)


def test_an_export_keeps_each_robots_protocol_and_the_sites_unattended_policy(site, robot):
    from robots.services import robot_protocol_declare

    robot_protocol_declare(
        robot=robot, protocol="vda5050", manufacturer="acme", serial_number="SN-7"
    )
    Site.objects.filter(pk=site.pk).update(unattended_timeout=2400.0)
    site.refresh_from_db()

    document = site_file_parse(document_yaml(site_document(site)), name="tiny.yaml")
    site_load(data=document)

    robot = Robot.objects.get(pk=robot.pk)
    assert (robot.protocol, robot.manufacturer, robot.serial_number) == ("vda5050", "acme", "SN-7")
    assert Site.objects.get(pk=site.pk).unattended_timeout == 2400.0
