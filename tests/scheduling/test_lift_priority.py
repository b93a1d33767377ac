"""Lift priority (resources/availability.py): an emergency team needs a lift now. The robot
inside finishes its ride, a grant not used yet is taken back, nobody is granted the lift until
it is released, and the robots waiting are told it is out of service to them; one confirmed
action on the fleet page or one API call each way, and every page shows it."""

import copy

import pytest
from django.test import Client

from boards.models import BoardMessage
from hospital_delivery.models import ApiToken
from resources.choices import LeaseState
from resources.models import Lease
from robots.models import Alert, Resource, Robot
from scheduling.choices import TaskStatus
from scheduling.models import OperatorAction
from scheduling.services import resource_operator_set_priority, site_reroute
from tests import factories
from tests.factories import lease_acquire, lease_enter, lease_release
from tests.scheduling.conftest import request, robot_ready, status
from tests.scheduling.test_out_of_service import TWO_LIFTS, vias

URL = "/api/v1/sites/tiny/resources/ELEV/priority"


@pytest.fixture
def lift(site):
    return Resource.objects.get(site=site, code="ELEV")


def robots_on(site, *codes):
    return [robot_ready(factories.robot_create(site, code), at="1F-ELEV-WAIT") for code in codes]


def told_out_of_service(robot) -> bool:
    pending = BoardMessage.objects.pending().filter(robot=robot, type="resource_out_of_service")
    return pending.exists()


def test_the_rider_finishes_and_nobody_is_granted_the_lift_until_it_is_released(
    site, lift, operator
):
    inside, waiting, late = robots_on(site, "R1", "R2", "R3")
    riding = lease_acquire(robot=inside, resource=lift, request_id="q-1", to_floor="2F")
    lease_enter(robot=inside, resource=lift)
    queued = lease_acquire(robot=waiting, resource=lift, request_id="q-2", to_floor="3F")

    held = resource_operator_set_priority(resource=lift, on=True, by=operator, reason="code blue")

    assert held.action == "lift_priority"
    riding.refresh_from_db()
    assert riding.state == LeaseState.ENTERED  # finishes its ride
    assert told_out_of_service(waiting)
    [alert] = Alert.objects.open().filter(kind="lift_priority")
    assert "ELEV is held for an emergency team by park: code blue" in alert.message
    lease_release(robot=inside, resource=lift)
    queued.refresh_from_db()
    assert queued.state == LeaseState.QUEUED  # the car is free, but not for robots
    asked = lease_acquire(robot=late, resource=lift, request_id="q-3", to_floor="2F")
    assert asked.state == LeaseState.QUEUED
    assert told_out_of_service(late)
    assert resource_operator_set_priority(resource=lift, on=True, by=operator, reason="") is None

    released = resource_operator_set_priority(resource=lift, on=False, by=operator)

    assert released.action == "priority_end"
    queued.refresh_from_db()
    assert queued.state == LeaseState.GRANTED  # in their order
    assert not Alert.objects.open().filter(kind="lift_priority").exists()
    assert OperatorAction.objects.filter(resource=lift).count() == 2


def test_a_grant_not_used_yet_is_taken_back(site, lift, operator):
    [robot] = robots_on(site, "R1")
    granted = lease_acquire(robot=robot, resource=lift, request_id="q-1", to_floor="2F")
    assert granted.state == LeaseState.GRANTED

    resource_operator_set_priority(resource=lift, on=True, by=operator, reason="trauma team")

    granted.refresh_from_db()
    assert (granted.state, granted.expires_at) == (LeaseState.QUEUED, None)
    [queued] = BoardMessage.objects.pending().filter(robot=robot, key=granted.board_key)
    assert queued.type == "resource_queued"


@pytest.fixture
def api(site):
    """A building management system: an operator of the site with an API token."""
    user = factories.user_create("bms", "operator")
    return Client(HTTP_AUTHORIZATION=f"Bearer {ApiToken.issue(user)}")


def test_a_building_system_holds_and_releases_a_lift(api, site, lift):
    held = api.post(URL, {"reason": "code blue, 3F"}, content_type="application/json")
    assert held.status_code == 200, held.content
    assert held.json()["priority_reason"] == "code blue, 3F"
    assert held.json()["priority_since"] is not None
    again = api.post(URL, {"reason": "again"}, content_type="application/json")
    assert again.status_code == 409

    released = api.post(f"{URL}/end", content_type="application/json")
    assert released.status_code == 200, released.content
    assert released.json()["priority_since"] is None
    assert api.post(f"{URL}/end", content_type="application/json").status_code == 409


@pytest.mark.parametrize(
    ("path", "body", "status", "field"),
    [
        (URL, {}, 400, "reason"),
        (URL, {"reason": 5}, 400, "reason"),
        (URL, {"reason": "x" * 201}, 400, "reason"),
        ("/api/v1/sites/tiny/resources/DOOR-2F/priority", {"reason": "x"}, 404, None),
        ("/api/v1/sites/tiny/resources/NOPE/priority", {"reason": "x"}, 404, None),
    ],
)
def test_bad_input_is_refused_and_changes_nothing(api, site, lift, path, body, status, field):
    refused = api.post(path, body, content_type="application/json")
    assert refused.status_code == status, refused.content
    if field:
        assert field in refused.json()["detail"]
    assert not Resource.objects.filter(priority_since__isnull=False).exists()
    assert not OperatorAction.objects.exists()


def test_an_operator_holds_it_on_the_fleet_page_and_every_page_shows_it(site, operator, nurse):
    page = Client()
    page.force_login(operator)
    assert "Lift priority" in page.get("/fleet/?site=tiny").content.decode()
    refused = page.post("/resources/tiny/ELEV/priority", {"on": "true"})
    assert (refused.status_code, list(refused.json()["detail"])) == (400, ["reason"])

    held = page.post("/resources/tiny/ELEV/priority", {"on": "true", "reason": "code blue"})

    assert held.status_code == 302
    fleet = page.get("/fleet/?site=tiny").content.decode()
    assert "Held for an emergency team" in fleet
    assert "Release lift" in fleet
    ward = Client()
    ward.force_login(nurse)
    assert "ELEV is held for an emergency team" in ward.get("/").content.decode()
    alert = Alert.objects.open().get(kind="lift_priority")
    page.post(f"/alerts/{alert.pk}/acknowledge")
    assert Alert.objects.open().filter(pk=alert.pk).exists()  # stays until released

    page.post("/resources/tiny/ELEV/priority", {"on": "false"})
    assert "ELEV is held for an emergency team" not in ward.get("/").content.decode()


def two_lifts_and_a_top_floor() -> dict:
    """The two-lift site, with a 4F that only ELEV serves."""
    data = copy.deepcopy(TWO_LIFTS)
    data["site"] = "twolifts4"
    top = data["floors"][3]
    top["waypoints"] += [
        {"code": "4F-ELEV-WAIT", "x": 20, "y": 0, "kind": "resource_wait"},
        {"code": "4F-WARD", "x": 0, "y": 10, "kind": "station", "name": "Ward 4"},
    ]
    top["edges"] = [["4F-HALL", "4F-ELEV-WAIT"], ["4F-HALL", "4F-WARD"]]
    data["resources"][0]["stops"]["4F"] = "4F-ELEV-WAIT"
    return data


def given(site, code: str, dropoff: str):
    """A robot at 1F given a delivery from the pharmacy to `dropoff`, and no other."""
    robot = robot_ready(factories.robot_create(site, code))
    task = request(site, dropoffs=(dropoff,), allocate_now=True)
    assert status(task) == TaskStatus.ASSIGNED
    Robot.objects.filter(pk=robot.pk).update(status="paused")  # offered nothing more
    return robot, task


def test_with_two_lifts_the_robots_queued_go_by_the_other_and_the_rest_wait(operator):
    site = factories.site_create(**two_lifts_and_a_top_floor())
    lift = Resource.objects.get(site=site, code="ELEV")
    first, _ = given(site, "R1", "2F-LAB")
    top, _ = given(site, "R2", "4F-WARD")
    assert vias(first)[-1] == ["1F-ELEV-WAIT", "2F-ELEV-WAIT"]
    assert vias(top)[-1] == ["1F-ELEV-WAIT", "4F-ELEV-WAIT"]
    [rider] = robots_on(site, "R3")
    lease_acquire(robot=rider, resource=lift, request_id="q-ride", to_floor="3F")
    lease_enter(robot=rider, resource=lift)
    queued = {
        robot.code: lease_acquire(
            robot=robot, resource=lift, request_id=f"q-{robot.code}", to_floor=floor
        )
        for robot, floor in ((first, "2F"), (top, "4F"))
    }
    for robot in (first, top):  # back where they wait, as their heartbeats say
        robot_ready(robot, at="1F-ELEV-WAIT", status="waiting_resource")
    assert {lease.state for lease in queued.values()} == {LeaseState.QUEUED}

    resource_operator_set_priority(resource=lift, on=True, by=operator, reason="code blue")

    assert told_out_of_service(first)
    assert told_out_of_service(top)
    assert site_reroute(site_id=site.pk) == ["R1"]
    assert vias(first)[-1] == ["1F-ELEVB-WAIT", "2F-ELEVB-WAIT"]  # by the other lift
    assert vias(top)[-1] == ["1F-ELEV-WAIT", "4F-ELEV-WAIT"]  # no other way: it waits
    # R1 follows its new plan: it gives up its place and takes the other lift at once.
    lease_release(robot=first, resource=lift)
    other = Resource.objects.get(site=site, code="ELEV-B")
    taken = lease_acquire(robot=first, resource=other, request_id="q-b", to_floor="2F")
    assert taken.state == LeaseState.GRANTED
    lease_release(robot=rider, resource=lift)  # the rider finishes: the car is not given on
    assert Lease.objects.get(pk=queued["R2"].pk).state == LeaseState.QUEUED

    resource_operator_set_priority(resource=lift, on=False, by=operator)
    assert Lease.objects.get(pk=queued["R2"].pk).state == LeaseState.GRANTED
