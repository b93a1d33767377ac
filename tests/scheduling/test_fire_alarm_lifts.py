"""A fire alarm and the robots riding a lift (building.services.elevator_riders_let_out): the
car stops at its next floor, the robot inside is told `elevator_exit`, gets out and waits;
nobody is granted a lift; the all-clear lets its delivery finish, once. Time is driven: the
simulated car is stepped from the moment the robot got in."""

import copy
from datetime import timedelta

import pytest

from boards.choices import MessageType
from boards.models import BoardMessage
from building.models import Device
from building.services import sim_step
from resources.choices import LeaseState
from resources.models import Lease
from robots.models import Resource
from scheduling.choices import TaskStatus
from scheduling.services import emergency_end, emergency_start
from tests import factories
from tests.scheduling.conftest import Beater, event, plans, request, robot_ready, route, status


def with_refuge_on_2f() -> dict:
    """The tiny site with a refuge point on 2F, off the lift lobby."""
    data = copy.deepcopy(factories.TINY_SITE)
    second = data["floors"][1]
    second["waypoints"].append(
        {"code": "2F-REFUGE", "x": 10, "y": 0, "kind": "refuge", "name": "2F refuge"}
    )
    second["edges"].append(["2F-ELEV-WAIT", "2F-REFUGE"])
    return data


@pytest.fixture
def site(db, operator):
    return factories.site_create(**with_refuge_on_2f())


@pytest.fixture
def lift(site):
    return Resource.objects.get(site=site, code="ELEV")


def car(lift, *, after: float) -> Device:
    """Step the simulated car to `after` seconds past the first robot's getting in."""
    rides = Lease.objects.filter(resource=lift, entered_at__isnull=False).order_by("pk")
    entered = rides.first().entered_at
    sim_step(device=Device.objects.get(resource=lift), now=entered + timedelta(seconds=after))
    return Device.objects.select_related("current_floor", "requested_floor").get(resource=lift)


def board(robot, type: str) -> list[dict]:
    pending = BoardMessage.objects.pending().filter(robot=robot, type=type).order_by("pk")
    return [message.body for message in pending]


def rider(site, lift):
    """R1 has loaded a delivery for 3F at the pharmacy and got into the lift at 1F."""
    robot = robot_ready(factories.robot_create(site, "R1"))
    task = request(site, dropoffs=("3F-WARD",), allocate_now=True)
    beater = Beater(robot)
    [plan] = plans(beater.beat())
    beater.beat(acks=[plan["id"]])
    beater.beat(waypoint="1F-PHARM", events=[event("loaded", task.code, 0)])
    assert status(task) == TaskStatus.PICKED_UP
    acquire = {"id": "q-up", "type": "acquire", "resource": "ELEV", "to_floor": "3F"}
    beater.beat(status="waiting_resource", waypoint="1F-ELEV-WAIT", requests=[acquire], load=1)
    entered = event("resource_entered", resource="ELEV")
    beater.beat(status="in_resource", waypoint="1F-ELEV-WAIT", events=[entered], load=1)
    return robot, task, beater


def test_a_robot_riding_between_floors_gets_out_at_the_next_one_and_waits(site, lift, operator):
    robot, task, beater = rider(site, lift)
    moving = car(lift, after=1)
    assert (moving.current_floor.code, moving.motion) == ("1F", "up")  # on its way to 3F
    waiting = robot_ready(factories.robot_create(site, "R2"), at="3F-ELEV-WAIT")
    queued = factories.lease_acquire(
        robot=waiting, resource=lift, request_id="q-down", to_floor="1F"
    )
    assert queued.state == LeaseState.QUEUED

    emergency_start(site=site, floors=["2F", "3F"], reason="zone 3", via="api", by=operator)

    lease = Lease.objects.get(robot=robot, resource=lift)
    assert board(robot, MessageType.ELEVATOR_EXIT) == [
        {
            "resource": "ELEV",
            "lease": lease.public_id,
            "floor": "2F",
            "waypoint": "2F-ELEV-WAIT",
            "reason": "fire alarm: zone 3",
        }
    ]
    assert car(lift, after=2).requested_floor.code == "2F"
    stopped = car(lift, after=5)
    assert (stopped.current_floor.code, stopped.motion, stopped.door) == ("2F", "stopped", "open")
    assert board(robot, MessageType.ELEVATOR_AT_FLOOR)[-1]["floor"] == "2F"

    # Out at 2F: the lease ends, nobody is given the car, the robot goes to 2F's refuge.
    reply = beater.beat(
        status="moving",
        waypoint="2F-ELEV-WAIT",
        load=1,
        events=[event("resource_released", resource="ELEV")],
    )
    lease.refresh_from_db()
    assert lease.state == LeaseState.RELEASED
    queued.refresh_from_db()
    assert queued.state == LeaseState.QUEUED
    [refuge] = plans(reply)
    assert route(refuge)[0] == (None, None, "dock", "2F-REFUGE")
    assert route(refuge)[-1] == (task.code, 1, "dropoff", "3F-WARD")  # still its own
    beater.beat(status="idle", waypoint="2F-REFUGE", load=1, acks=[refuge["id"]])
    assert status(task) == TaskStatus.PICKED_UP

    emergency_end(site=site, via="api", by=operator)

    queued.refresh_from_db()
    assert queued.state == LeaseState.GRANTED  # the queue is served in its order
    [onwards] = plans(beater.beat(status="idle", waypoint="2F-REFUGE", load=1))
    assert route(onwards) == [(task.code, 1, "dropoff", "3F-WARD")]
    factories.lease_release(robot=waiting, resource=lift)
    again = {"id": "q-up-again", "type": "acquire", "resource": "ELEV", "to_floor": "3F"}
    reply = beater.beat(
        status="waiting_resource",
        waypoint="2F-ELEV-WAIT",
        load=1,
        acks=[onwards["id"]],
        requests=[again],
    )
    grants = [m for m in reply["messages"] if m["type"] == "resource_grant"]
    assert [grant["request"] for grant in grants] == ["q-up-again"]
    ride = [event("resource_entered", resource="ELEV"), event("resource_released", resource="ELEV")]
    beater.beat(status="moving", waypoint="3F-ELEV-WAIT", load=1, events=ride)
    beater.beat(waypoint="3F-WARD", events=[event("unloaded", task.code, 1)])
    beater.beat(waypoint="3F-WARD", events=[event("task_completed", task.code)])
    assert status(task) == TaskStatus.COMPLETED
    task.refresh_from_db()
    assert task.robot_id == robot.pk


def test_a_car_standing_with_its_robot_opens_where_it_is(site, lift, operator):
    robot, _task, _beater = rider(site, lift)
    emergency_start(site=site, floors=[], reason="", via="operator", by=operator)
    [told] = board(robot, MessageType.ELEVATOR_EXIT)
    assert (told["floor"], told["waypoint"], told["reason"]) == (
        "1F",
        "1F-ELEV-WAIT",
        "fire alarm",
    )
    standing = car(lift, after=0)
    assert (standing.current_floor.code, standing.requested_floor.code) == ("1F", "1F")


def test_a_robot_that_stays_in_rides_on_at_the_all_clear(site, lift, operator):
    robot, _task, _beater = rider(site, lift)
    car(lift, after=1)
    emergency_start(site=site, floors=["1F"], reason="", via="api", by=operator)
    assert car(lift, after=5).current_floor.code == "2F"

    emergency_end(site=site, via="api", by=operator)

    # A robot that did not hear the message (no network in the cabin, or a v1 robot) is
    # taken on to the floor it asked for; the message it never read is withdrawn.
    assert board(robot, MessageType.ELEVATOR_EXIT) == []
    assert car(lift, after=5).requested_floor.code == "3F"
    lease = Lease.objects.get(robot=robot, resource=lift)
    assert lease.state == LeaseState.ENTERED
