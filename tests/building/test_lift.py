"""The simulated lift and door follow the leases (building/services.py), time driven, no sleeps."""

from datetime import timedelta

import pytest
from django.utils import timezone

from boards.choices import MessageType
from boards.models import BoardMessage
from building.models import Device
from building.services import Report, device_report, silence_sweep, sim_step
from resources.choices import LeaseState
from robots.models import Alert, AlertKind, Floor, Resource
from tests import factories
from tests.factories import lease_acquire, lease_enter, lease_release

START = timezone.now()


def at(seconds: float):
    return START + timedelta(seconds=seconds)


@pytest.fixture
def elevator(site):
    return Resource.objects.get(site=site, code="ELEV")


@pytest.fixture
def door(site):
    return Resource.objects.get(site=site, code="DOOR-2F")


def lift_of(resource) -> Device:
    return Device.objects.select_related("current_floor", "requested_floor").get(resource=resource)


def floor(device: Device) -> str | None:
    return device.current_floor.code if device.current_floor else None


def run(device: Device, seconds: float) -> Device:
    sim_step(device=Device.objects.get(pk=device.pk), now=at(seconds))
    return lift_of(device.resource)


def robot_on(site, code: str, floor_code: str):
    robot = factories.robot_create(site, code)
    robot.floor = Floor.objects.get(site=site, code=floor_code)
    robot.save(update_fields=["floor"])
    return robot


def at_floor_messages(robot) -> list[dict]:
    pending = BoardMessage.objects.pending().filter(robot=robot, type=MessageType.ELEVATOR_AT_FLOOR)
    return [message.body for message in pending]


def test_it_calls_the_car_to_the_robots_floor_then_sends_it_to_the_destination(site, elevator):
    robot = robot_on(site, "R1", "2F")
    lease = lease_acquire(
        robot=robot, resource=elevator, request_id="q-1", to_floor="3F", now=at(0)
    )
    assert lease.state == LeaseState.GRANTED
    lift = lift_of(elevator)
    assert (floor(lift), lift.requested_floor.code, lift.session) == ("1F", "2F", lease.public_id)

    lift = run(lift, 1)  # doors were closed at 1F: the car sets off upwards
    assert (floor(lift), lift.motion) == ("1F", "up")
    lift = run(lift, 2.4)  # 2.5 s per floor: not there yet
    assert floor(lift) == "1F"
    lift = run(lift, 2.6)
    assert (floor(lift), lift.motion, lift.door) == ("2F", "stopped", "moving")
    assert at_floor_messages(robot) == []  # doors not open yet
    lift = run(lift, 5)
    assert lift.door == "open"
    assert at_floor_messages(robot) == [
        {"resource": "ELEV", "lease": lease.public_id, "floor": "2F", "doors": "open"}
    ]
    lift = run(lift, 60)  # the doors stay held open for the robot
    assert (floor(lift), lift.door) == ("2F", "open")

    lease_enter(robot=robot, resource=elevator, now=at(61))
    lift = lift_of(elevator)
    assert lift.requested_floor.code == "3F"
    lift = run(lift, 62)
    assert (floor(lift), lift.door) == ("2F", "moving")  # closing before it moves
    lift = run(lift, 63.5)
    assert (floor(lift), lift.door, lift.motion) == ("2F", "closed", "up")
    lift = run(lift, 66.5)
    assert (floor(lift), lift.motion) == ("3F", "stopped")
    lift = run(lift, 69)
    assert lift.door == "open"
    assert at_floor_messages(robot)[-1]["floor"] == "3F"  # replaces the unacked 2F one
    assert len(at_floor_messages(robot)) == 1

    lease_release(robot=robot, resource=elevator, now=at(70))
    lift = lift_of(elevator)
    assert (lift.session, lift.requested_door) == ("", "closed")
    lift = run(lift, 73)
    assert (floor(lift), lift.door) == ("3F", "closed")


def test_it_serves_the_next_in_line_from_where_the_car_is(site, elevator):
    first, second = robot_on(site, "R1", "1F"), robot_on(site, "R2", "3F")
    lease_acquire(robot=first, resource=elevator, request_id="q-1", to_floor="2F", now=at(0))
    queued = lease_acquire(robot=second, resource=elevator, request_id="q-2", to_floor="1F")
    assert queued.state == LeaseState.QUEUED
    assert lift_of(elevator).requested_floor.code == "1F"  # the queue does not move the car

    lease_release(robot=first, resource=elevator, now=at(10))
    lift = lift_of(elevator)
    assert (lift.requested_floor.code, lift.session) == ("3F", f"L-{queued.pk}")


def test_it_opens_a_door_for_its_holder_and_closes_it_after(site, door):
    robot = robot_on(site, "R1", "2F")
    lease_acquire(robot=robot, resource=door, request_id="q-1", now=at(0))
    device = lift_of(door)
    assert device.requested_door == "open"
    device = run(device, 0.5)
    assert device.door == "moving"
    device = run(device, 2)
    assert device.door == "open"
    lease_release(robot=robot, resource=door, now=at(10))
    device = run(lift_of(door), 12)
    assert device.door == "closed"


def test_a_faulted_lift_takes_its_resource_out_of_service(site, elevator):
    robot = robot_on(site, "R1", "1F")
    lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="2F", now=at(0))
    waiting = robot_on(site, "R2", "3F")
    lease_acquire(robot=waiting, resource=elevator, request_id="q-2", to_floor="1F", now=at(1))

    device_report(
        device=lift_of(elevator), report=Report(door="closed", floor="1F", fault="fire"), now=at(2)
    )

    elevator.refresh_from_db()
    assert not elevator.in_service
    assert "fire" in elevator.out_of_service_reason
    told = BoardMessage.objects.pending().filter(type=MessageType.RESOURCE_OUT_OF_SERVICE)
    assert {message.robot.code for message in told} == {"R1", "R2"}
    alert = Alert.objects.open().get(kind=AlertKind.RESOURCE_OUT_OF_SERVICE)
    assert alert.resource == elevator

    # R1 releases: R2 is not granted a lift that is out of service; it is held in the queue.
    lease_release(robot=robot, resource=elevator, now=at(3))
    assert waiting.leases.get().state == LeaseState.QUEUED


def test_a_silent_lift_is_taken_out_of_service(site, elevator, settings):
    settings.BUILDING_REPORT_TIMEOUT = 10
    robot = robot_on(site, "R1", "1F")
    lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="2F")
    lift = lift_of(elevator)
    heard = lift.reported_at

    assert silence_sweep(now=heard + timedelta(seconds=9)) == 0
    assert silence_sweep(now=heard + timedelta(seconds=11)) == 1
    elevator.refresh_from_db()
    assert not elevator.in_service
    assert "has not reported" in elevator.out_of_service_reason
    assert silence_sweep(now=heard + timedelta(seconds=12)) == 0  # once


def test_it_runs_the_simulated_lift_faster_when_told(site, elevator, settings):
    settings.BUILDING_SIM_SPEEDUP = 10  # the VDA 5050 tests' vehicles drive faster than real
    robot = robot_on(site, "R1", "2F")
    lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="3F", now=at(0))
    lift = run(lift_of(elevator), 0.1)  # the car sets off upwards from 1F
    lift = run(lift, 0.24)  # 2.5 s per floor, ten times faster: not there yet
    assert floor(lift) == "1F"
    lift = run(lift, 0.26)
    assert (floor(lift), lift.door) == ("2F", "moving")
    lift = run(lift, 0.44)  # its doors open in 0.2 s, not 2
    assert lift.door == "moving"
    lift = run(lift, 0.46)
    assert lift.door == "open"
    assert [m["floor"] for m in at_floor_messages(robot)] == ["2F"]
