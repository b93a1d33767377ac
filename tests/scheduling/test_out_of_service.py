"""Resources out of service (resources/availability.py): routes go round them where another way
exists and are re-planned; robots with no other way are held in the queue, never failed."""

import copy

import pytest
from django.test import override_settings

from boards.choices import MessageType
from boards.models import BoardMessage
from resources.choices import LeaseState
from robots.mapcache import router_for
from robots.models import Resource
from scheduling import tasks as celery_tasks
from scheduling.choices import ResourceActionKind, TaskStatus
from scheduling.models import OperatorAction
from scheduling.services import resource_operator_set_service, site_reroute
from tests import factories
from tests.factories import TINY_SITE, lease_acquire
from tests.scheduling.conftest import pending_plans, request, robot_ready, status

# The tiny site with a second, farther elevator beside the first.
TWO_LIFTS = copy.deepcopy(TINY_SITE)
TWO_LIFTS["site"] = "twolifts"
for number, floor in enumerate(TWO_LIFTS["floors"][:3], start=1):
    lobby = f"{floor['code']}-ELEVB-WAIT"
    floor["waypoints"].append({"code": lobby, "x": 20, "y": -40, "kind": "resource_wait"})
    near = {1: "1F-HALL", 2: "2F-ELEV-WAIT", 3: "3F-ELEV-WAIT"}[number]
    floor["edges"].append({"from": near, "to": lobby, "length": 40})
TWO_LIFTS["resources"].append(
    {
        "code": "ELEV-B",
        "kind": "elevator",
        "capacity": 1,
        "stops": {"1F": "1F-ELEVB-WAIT", "2F": "2F-ELEVB-WAIT", "3F": "3F-ELEVB-WAIT"},
        "seconds_per_floor": 2.5,
        "overhead_seconds": 30,
    }
)


@pytest.fixture
def two_lifts(db):
    return factories.site_create(**TWO_LIFTS)


def elevator(site, code="ELEV") -> Resource:
    return Resource.objects.select_related("site").get(site=site, code=code)


def vias(robot) -> list[list[str]]:
    plan = pending_plans(robot)[-1]
    return [stop.get("via", []) for stop in plan.body["stops"]]


def test_it_reroutes_a_plan_round_a_lift_taken_out_of_service(two_lifts, operator):
    robot = robot_ready(factories.robot_create(two_lifts, "R1"))
    task = request(two_lifts, allocate_now=True)
    assert status(task) == TaskStatus.ASSIGNED
    assert vias(robot)[-1] == ["1F-ELEV-WAIT", "2F-ELEV-WAIT"]

    action = resource_operator_set_service(
        resource=elevator(two_lifts), in_service=False, by=operator, reason="maintenance"
    )
    assert action.action == ResourceActionKind.OUT_OF_SERVICE
    assert (action.resource.code, action.by, action.note) == ("ELEV", operator, "maintenance")

    assert site_reroute(site_id=two_lifts.pk) == ["R1"]
    assert vias(robot)[-1] == ["1F-ELEVB-WAIT", "2F-ELEVB-WAIT"]
    assert site_reroute(site_id=two_lifts.pk) == []  # unchanged routes get no new plan

    resource_operator_set_service(resource=elevator(two_lifts), in_service=True, by=operator)
    assert site_reroute(site_id=two_lifts.pk) == ["R1"]
    assert vias(robot)[-1] == ["1F-ELEV-WAIT", "2F-ELEV-WAIT"]
    kinds = list(OperatorAction.objects.order_by("pk").values_list("action", flat=True))
    assert kinds == [ResourceActionKind.OUT_OF_SERVICE, ResourceActionKind.BACK_IN_SERVICE]


def test_a_robot_with_no_other_way_is_held_in_the_queue_not_failed(site, operator):
    robot = robot_ready(factories.robot_create(site, "R1"))
    lift = elevator(site)
    resource_operator_set_service(resource=lift, in_service=False, by=operator, reason="repair")

    task = request(site, allocate_now=True)
    assert status(task) == TaskStatus.ASSIGNED  # through the only lift: it will wait for it
    assert vias(robot)[-1] == ["1F-ELEV-WAIT", "2F-ELEV-WAIT"]

    lease = lease_acquire(robot=robot, resource=lift, request_id="q-1", to_floor="2F")
    assert lease.state == LeaseState.QUEUED
    types = set(BoardMessage.objects.pending().filter(robot=robot).values_list("type", flat=True))
    assert {MessageType.RESOURCE_QUEUED, MessageType.RESOURCE_OUT_OF_SERVICE} <= types

    resource_operator_set_service(resource=elevator(site), in_service=True, by=operator)
    lease.refresh_from_db()
    assert lease.state == LeaseState.GRANTED
    latest = BoardMessage.objects.pending().filter(robot=robot, key=f"service:{lift.pk}").get()
    assert latest.type == MessageType.RESOURCE_IN_SERVICE  # replaced the unacked notice
    assert status(task) == TaskStatus.ASSIGNED


def test_the_router_goes_round_a_closed_lift_and_through_it_only_if_it_must(two_lifts):
    lift = elevator(two_lifts)
    before = router_for(two_lifts).leg("1F-PHARM", "2F-LAB")
    assert before.resources[0] == "ELEV"
    resource_operator_set_service(resource=lift, in_service=False, by=None, reason="x")
    two_lifts.refresh_from_db()
    router = router_for(two_lifts)
    assert router.leg("1F-PHARM", "2F-LAB").resources[0] == "ELEV-B"
    assert router.travel_time("1F-PHARM", "2F-LAB") > before.seconds

    resource_operator_set_service(
        resource=elevator(two_lifts, "ELEV-B"), in_service=False, by=None, reason="y"
    )
    two_lifts.refresh_from_db()
    leg = router_for(two_lifts).leg("1F-PHARM", "2F-LAB")
    assert leg.resources[0] == "ELEV"  # no way round: through the closed one (the robot waits)
    assert leg.path[-1] == "2F-LAB"


@override_settings(BUILDING_ADAPTER="none")
def test_it_changes_nothing_taking_out_a_resource_already_out(site, operator):
    lift = elevator(site)
    assert resource_operator_set_service(resource=lift, in_service=False, by=operator, reason="a")
    assert (
        resource_operator_set_service(resource=lift, in_service=False, by=operator, reason="b")
        is None
    )
    lift.refresh_from_db()
    assert lift.out_of_service_reason == "a"
    assert OperatorAction.objects.count() == 1


def test_taking_a_lift_out_asks_a_worker_to_reroute_after_commit(
    site, operator, monkeypatch, django_capture_on_commit_callbacks
):
    sent = []
    monkeypatch.setattr(celery_tasks.site_reroute, "delay", lambda *args: sent.append(args))
    with django_capture_on_commit_callbacks(execute=False) as callbacks:
        resource_operator_set_service(
            resource=elevator(site), in_service=False, by=operator, reason="x"
        )
    assert sent == []  # nothing before the commit: robot rows are locked before resources
    for callback in callbacks:
        callback()
    assert sent == [(site.pk, "ELEV")]
