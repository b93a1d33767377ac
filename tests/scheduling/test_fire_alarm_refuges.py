"""A fire alarm with refuge points (scheduling/services/emergency.py): a robot that can reach
one on its floor without a lift is sent there by a plan and keeps its tasks; the others stop
where they are, but not in a lift lobby; a lift granted and not entered is taken back."""

import pytest

from boards.models import BoardMessage
from resources.choices import LeaseState
from resources.models import Lease
from robots.models import Resource
from robots.sitefile import SiteFileInvalid, site_load
from scheduling.models import RobotPlan
from scheduling.services import emergency_end, emergency_start, task_cancel
from tests import factories
from tests.factories import lease_acquire
from tests.scheduling.conftest import Beater, request, robot_ready, route


def with_refuge() -> dict:
    return factories.tiny_site_with_refuge()


@pytest.fixture
def site(db, operator):
    return factories.site_create(**with_refuge())


def plan_of(robot) -> dict:
    return RobotPlan.objects.get(robot=robot).body


def actions(robot) -> list[str]:
    pending = BoardMessage.objects.pending().filter(robot=robot, type="action").order_by("pk")
    return [message.body["action"] for message in pending]


def test_it_sends_a_robot_with_a_refuge_on_its_floor_there_and_pauses_the_others(site, operator):
    r1 = robot_ready(factories.robot_create(site, "R1"))
    r3 = robot_ready(factories.robot_create(site, "R3"), at="3F-WARD")

    alarm = emergency_start(site=site, floors=[], reason="", via="operator", by=operator)

    assert alarm.refuges == {"R1": "1F-REFUGE"}
    assert alarm.stopped_robots == ["R3"]
    assert route(plan_of(r1)) == [(None, None, "dock", "1F-REFUGE")]
    assert actions(r1) == []
    assert actions(r3) == ["pause"]

    ended = emergency_end(site=site, via="operator", by=operator)

    assert ended.resumed == ["R3"]
    assert route(plan_of(r1)) == [(None, None, "dock", "1F-DOCK-1")]


def test_a_robot_at_its_refuge_keeps_its_tasks_until_the_all_clear(site, operator):
    r1 = robot_ready(factories.robot_create(site, "R1"))
    kept = request(site, allocate_now=True)
    cancelled = request(site, dropoffs=("3F-WARD",), allocate_now=True)
    assert {kept.code, cancelled.code} == set(plan_of(r1)["tasks"])

    emergency_start(site=site, floors=["1F"], reason="", via="api", by=operator)

    plan = plan_of(r1)
    assert route(plan)[0] == (None, None, "dock", "1F-REFUGE")
    assert {stop[0] for stop in route(plan)[1:]} == {kept.code, cancelled.code}
    # A plan posted for any other reason during the alarm still starts at the refuge.
    task_cancel(task=cancelled, by=operator)
    assert route(plan_of(r1)) == [
        (None, None, "dock", "1F-REFUGE"),
        (kept.code, 0, "pickup", "1F-PHARM"),
        (kept.code, 1, "dropoff", "2F-LAB"),
    ]

    emergency_end(site=site, via="api", by=operator)
    assert route(plan_of(r1)) == [
        (kept.code, 0, "pickup", "1F-PHARM"),
        (kept.code, 1, "dropoff", "2F-LAB"),
    ]


def test_a_robot_in_a_lift_lobby_without_a_refuge_stops_once_out_of_it(site, operator):
    robot = robot_ready(
        factories.robot_create(site, "R3"), at="3F-ELEV-WAIT", status="waiting_resource"
    )
    alarm = emergency_start(site=site, floors=["3F"], reason="", via="api", by=operator)
    assert (alarm.stopped_robots, alarm.refuges) == ([], {})
    beater = Beater(robot)
    beater.beat(status="waiting_resource", waypoint="3F-ELEV-WAIT")
    assert actions(robot) == []

    reply = beater.beat(status="moving", waypoint="3F-CORR-MID")

    assert [m["action"] for m in reply["messages"] if m["type"] == "action"] == ["pause"]
    alarm.refresh_from_db()
    assert alarm.stopped_robots == ["R3"]


def test_a_robot_reaching_a_floor_with_a_refuge_is_sent_there(site, operator):
    robot = robot_ready(factories.robot_create(site, "R1"), at="3F-WARD", status="moving")
    emergency_start(site=site, floors=["1F"], reason="", via="api", by=operator)
    beater = Beater(robot)

    reply = beater.beat(status="moving", waypoint="1F-HALL")

    [plan] = [m for m in reply["messages"] if m["type"] == "plan"]
    assert route(plan) == [(None, None, "dock", "1F-REFUGE")]
    beater.beat(status="moving", waypoint="1F-REFUGE")
    assert BoardMessage.objects.filter(robot=robot, type="plan").count() == 1
    assert actions(robot) == []


def test_it_takes_back_a_lift_granted_and_not_entered(site, operator):
    robot = robot_ready(factories.robot_create(site, "R3"), at="3F-ELEV-WAIT")
    lift = Resource.objects.get(site=site, code="ELEV")
    granted = lease_acquire(robot=robot, resource=lift, request_id="q-1", to_floor="1F")
    assert granted.state == LeaseState.GRANTED

    emergency_start(site=site, floors=["1F"], reason="", via="api", by=operator)

    granted.refresh_from_db()
    assert (granted.state, granted.granted_at, granted.expires_at) == (
        LeaseState.QUEUED,
        None,
        None,
    )
    [queued] = BoardMessage.objects.pending().filter(robot=robot, key=granted.board_key)
    assert (queued.type, queued.body["position"]) == ("resource_queued", 1)

    emergency_end(site=site, via="api", by=operator)
    assert Lease.objects.get(pk=granted.pk).state == LeaseState.GRANTED


def test_the_site_file_refuses_a_refuge_where_a_resource_waits(db):
    data = with_refuge()
    data["resources"][0]["stops"]["1F"] = "1F-REFUGE"
    with pytest.raises(SiteFileInvalid) as raised:
        site_load(data=data)
    assert any(
        "'1F-REFUGE' is a refuge point but a resource waits there" in p
        for p in raised.value.problems
    )
