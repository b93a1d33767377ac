"""A fire alarm (scheduling/services/emergency.py): robots on its floors stop, no lift is
granted, deliveries are held; the all-clear resumes them and allocates each delivery once."""

import pytest

from boards.models import BoardMessage
from resources.choices import LeaseState
from robots.models import Alert, AlertKind, Emergency, Resource, Site
from scheduling.choices import TaskStatus
from scheduling.services import (
    EmergencyRefused,
    emergency_end,
    emergency_start,
    robot_action,
    site_allocate_due,
)
from scheduling.services.allocation import HELD_BY_FIRE_ALARM
from tests import factories
from tests.factories import lease_acquire, lease_enter
from tests.scheduling.conftest import Beater, request, robot_ready, status


def actions(robot) -> list[str]:
    """The action messages still on the robot's board, oldest first."""
    pending = BoardMessage.objects.pending().filter(robot=robot, type="action").order_by("pk")
    return [message.body["action"] for message in pending]


@pytest.fixture
def on_3f(site):
    return robot_ready(factories.robot_create(site, "R3"), at="3F-WARD")


def test_it_stops_the_robots_on_its_floors_and_no_other(site, r1, on_3f, operator):
    alarm = emergency_start(site=site, floors=["1F"], reason="drill", via="operator", by=operator)

    assert alarm.stopped_robots == ["R1"]
    assert actions(r1) == ["pause"]
    assert actions(on_3f) == []
    site.refresh_from_db()
    assert site.fire_alarm_since == alarm.started_at
    [alert] = Alert.objects.open().filter(kind=AlertKind.FIRE_ALARM)
    assert "floors 1F" in alert.message
    assert "stopped where they are" in alert.message


def test_it_stops_every_robot_when_no_floor_is_named(site, r1, on_3f, operator):
    alarm = emergency_start(site=site, floors=[], reason="", via="api", by=operator)
    assert alarm.stopped_robots == ["R1", "R3"]
    assert actions(on_3f) == ["pause"]


def test_it_accepts_deliveries_but_plans_none_until_the_all_clear(site, r1, on_3f, operator):
    emergency_start(site=site, floors=["1F"], reason="", via="operator", by=operator)
    first = request(site, allocate_now=True)
    second = request(site, allocate_now=True)
    assert site_allocate_due(site_id=site.pk) == 0
    for task in (first, second):
        task.refresh_from_db()
        assert (task.status, task.robot_id) == (TaskStatus.DUE, None)
        assert task.waiting_reason == HELD_BY_FIRE_ALARM

    ended = emergency_end(site=site, via="operator", by=operator)

    assert ended.resumed == ["R1"]
    assert actions(r1) == ["resume"]  # the pause it had not acked is withdrawn
    assert ended.allocated == 2
    assert {status(first), status(second)} == {TaskStatus.ASSIGNED}
    assert site_allocate_due(site_id=site.pk) == 0  # nothing is allocated twice
    assert not Alert.objects.open().filter(kind=AlertKind.FIRE_ALARM).exists()
    site.refresh_from_db()
    assert site.fire_alarm_since is None


def test_it_grants_no_lift_until_the_all_clear(site, r1, on_3f, operator):
    lift = Resource.objects.get(site=site, code="ELEV")
    inside = lease_acquire(robot=on_3f, resource=lift, request_id="q-in", to_floor="1F")
    lease_enter(robot=on_3f, resource=lift)
    emergency_start(site=site, floors=["2F"], reason="", via="api", by=operator)

    # The robot inside keeps its lease; the next one waits, even once the car is free.
    inside.refresh_from_db()
    assert inside.state == LeaseState.ENTERED
    queued = lease_acquire(robot=r1, resource=lift, request_id="q-1", to_floor="2F")
    assert queued.state == LeaseState.QUEUED
    factories.lease_release(robot=on_3f, resource=lift)
    queued.refresh_from_db()
    assert queued.state == LeaseState.QUEUED

    emergency_end(site=site, via="api", by=operator)
    queued.refresh_from_db()
    assert queued.state == LeaseState.GRANTED


def test_it_leaves_a_robot_an_operator_paused_as_the_operator_left_it(site, r1, on_3f, operator):
    robot_action(robot=r1, action="pause", by=operator)
    alarm = emergency_start(site=site, floors=[], reason="", via="operator", by=operator)
    assert alarm.stopped_robots == ["R3"]
    robot_action(robot=on_3f, action="pause", by=operator)  # paused again during the alarm

    ended = emergency_end(site=site, via="operator", by=operator)

    assert ended.resumed == []
    assert actions(r1) == ["pause"]
    assert actions(on_3f) == ["pause"]


def test_it_refuses_a_second_alarm_an_unknown_floor_and_an_all_clear_without_one(
    site, r1, operator
):
    with pytest.raises(EmergencyRefused) as refused:
        emergency_start(site=site, floors=["9F"], reason="", via="api", by=operator)
    assert refused.value.field == "floors"
    assert not Emergency.objects.exists()
    assert actions(r1) == []
    with pytest.raises(EmergencyRefused):
        emergency_end(site=site, via="api", by=operator)

    emergency_start(site=site, floors=[], reason="", via="api", by=operator)
    with pytest.raises(EmergencyRefused):
        emergency_start(site=site, floors=["1F"], reason="", via="api", by=operator)
    assert Emergency.objects.count() == 1


def test_an_alarm_at_one_site_leaves_the_others_alone(site, r1, operator):
    other = factories.site_create(site="other")
    emergency_start(site=other, floors=[], reason="", via="api", by=operator)
    task = request(site, allocate_now=True)
    assert status(task) == TaskStatus.ASSIGNED
    assert Site.objects.get(pk=site.pk).fire_alarm_since is None


def test_a_robot_inside_a_resource_stops_once_out_of_it(site, operator):
    robot = robot_ready(factories.robot_create(site, "R1"), status="in_resource")
    alarm = emergency_start(site=site, floors=["1F"], reason="", via="api", by=operator)
    assert alarm.stopped_robots == []
    beater = Beater(robot)
    beater.beat(status="in_resource", waypoint="1F-ELEV-WAIT")
    assert actions(robot) == []

    reply = beater.beat(status="moving", waypoint="1F-HALL")

    assert [m["action"] for m in reply["messages"] if m["type"] == "action"] == ["pause"]
    beater.beat(status="moving", waypoint="1F-HALL")
    assert BoardMessage.objects.filter(robot=robot, type="action").count() == 1
    alarm.refresh_from_db()
    assert alarm.stopped_robots == ["R1"]
    assert emergency_end(site=site, via="api", by=operator).resumed == ["R1"]


def test_a_robot_reaching_another_floor_is_stopped_only_on_a_covered_one(site, operator):
    robot = robot_ready(factories.robot_create(site, "R1"), at="3F-WARD", status="moving")
    emergency_start(site=site, floors=["2F"], reason="", via="api", by=operator)
    beater = Beater(robot)
    beater.beat(status="moving", waypoint="3F-ELEV-WAIT")
    assert actions(robot) == []
    beater.beat(status="moving", waypoint="2F-ELEV-WAIT")
    assert actions(robot) == []  # not in the lift lobby: once out of it
    beater.beat(status="moving", waypoint="2F-LAB")
    assert actions(robot) == ["pause"]
