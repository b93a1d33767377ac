"""The MQTT adapter against a real Mosquitto (127.0.0.1:1883): the documented requests go out,
the documented states come in; a bad state is counted and changes nothing.

Each run uses a topic prefix of its own, so parallel runs on the shared broker never meet.
"""

import json
import queue
import time

from django.test import override_settings

from boards.choices import MessageType
from boards.models import BoardMessage
from building.models import Device
from building.services import device_stop_at_next_floor
from robots.models import Floor, Resource
from tests import factories
from tests.factories import lease_acquire, lease_enter

DEADLINE = 10.0  # seconds to wait for the broker; polled, never slept


def next_request(controller, topic: str) -> dict:
    deadline = time.monotonic() + DEADLINE
    while time.monotonic() < deadline:
        try:
            where, payload = controller.heard.get(timeout=0.1)
        except queue.Empty:
            continue
        if where == topic and payload:
            return json.loads(payload)
    raise AssertionError(f"nothing on {topic} within {DEADLINE} s")


def publish_state(controller, bridge, topic: str, payload, expect: str, retain=False) -> None:
    """Publish a state and run the bridge until it has applied or refused it: `expect`.
    Retained, it reaches a bridge still subscribing too."""
    raw = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
    before = (bridge.counts.applied, bridge.counts.invalid)
    controller.publish(topic, raw, qos=1, retain=retain).wait_for_publish(5)
    deadline = time.monotonic() + DEADLINE
    while (bridge.counts.applied, bridge.counts.invalid) == before:
        assert time.monotonic() < deadline, f"the bridge never read {topic}"
        bridge.run_once(wait=0.1)
    applied = bridge.counts.applied > before[0]
    assert ("applied" if applied else "invalid") == expect, bridge.counts.reasons


def lift_state(**fields) -> dict:
    state = {
        "lift_time": {"sec": 0, "nanosec": 0},
        "lift_name": "ELEV",
        "available_floors": ["1F", "2F", "3F"],
        "current_floor": "2F",
        "destination_floor": "2F",
        "door_state": 2,
        "motion_state": 0,
        "available_modes": [1, 2],
        "current_mode": 2,
        "session_id": "",
    }
    return state | fields


@override_settings(BUILDING_ADAPTER="mqtt")
def test_it_publishes_lift_requests_and_reads_lift_states(site, prefix, controller, bridge):
    robot = factories.robot_create(site, "R1")
    robot.floor = Floor.objects.get(site=site, code="2F")
    robot.save(update_fields=["floor"])
    elevator = Resource.objects.get(site=site, code="ELEV")
    lease = lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="3F")

    assert bridge.publish_pending() == 1
    requests = f"{prefix}/tiny/lift_requests/ELEV"
    call = next_request(controller, requests)
    assert call | {"request_time": None} == {
        "lift_name": "ELEV",
        "request_time": None,
        "session_id": lease.public_id,
        "request_type": 1,  # AGV mode: doors held open while stopped
        "destination_floor": "2F",
        "door_state": 2,
    }
    assert set(call["request_time"]) == {"sec", "nanosec"}
    assert bridge.publish_pending() == 0  # sent once

    states = f"{prefix}/tiny/lift_states/ELEV"
    publish_state(
        controller, bridge, states, lift_state(session_id=lease.public_id), expect="applied"
    )
    lift = Device.objects.select_related("current_floor").get(resource=elevator)
    assert (lift.current_floor.code, lift.door, lift.motion) == ("2F", "open", "stopped")
    told = BoardMessage.objects.pending().get(robot=robot, type=MessageType.ELEVATOR_AT_FLOOR)
    assert told.body["floor"] == "2F"

    lease_enter(robot=robot, resource=elevator)
    bridge.publish_pending()
    ride = next_request(controller, requests)
    assert (ride["destination_floor"], ride["session_id"]) == ("3F", lease.public_id)


@override_settings(BUILDING_ADAPTER="mqtt")
def test_a_car_is_stopped_at_its_next_floor_by_an_ordinary_request(
    site, prefix, controller, bridge
):
    robot = factories.robot_create(site, "R1")
    robot.floor = Floor.objects.get(site=site, code="3F")
    robot.save(update_fields=["floor"])
    elevator = Resource.objects.get(site=site, code="ELEV")
    lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="1F")
    lease = lease_enter(robot=robot, resource=elevator)
    bridge.publish_pending()
    requests = f"{prefix}/tiny/lift_requests/ELEV"
    assert next_request(controller, requests)["destination_floor"] == "1F"
    going_down = lift_state(
        current_floor="3F", destination_floor="1F", door_state=0, motion_state=2
    )
    states = f"{prefix}/tiny/lift_states/ELEV"
    publish_state(
        controller, bridge, states, going_down | {"session_id": lease.public_id}, "applied"
    )

    assert device_stop_at_next_floor(resource=elevator).code == "2F"

    assert bridge.publish_pending() == 1
    stop = next_request(controller, requests)
    assert (stop["session_id"], stop["request_type"]) == (lease.public_id, 1)
    assert (stop["destination_floor"], stop["door_state"]) == ("2F", 2)


@override_settings(BUILDING_ADAPTER="mqtt")
def test_bad_states_are_counted_and_change_nothing(site, prefix, controller, bridge):
    robot = factories.robot_create(site, "R1")
    elevator = Resource.objects.get(site=site, code="ELEV")
    lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="3F")
    states = f"{prefix}/tiny/lift_states/ELEV"
    bridge.publish_pending()
    before = Device.objects.values().get(resource=elevator)

    bad = [
        b"{not json",
        b"[1, 2]",
        lift_state(lift_name="OTHER"),
        lift_state(door_state=9),
        lift_state(motion_state="up"),
        lift_state(current_floor=None),
        lift_state(session_id=3),
        lift_state(current_floor="99F"),  # no such floor at the site
    ]
    for n, payload in enumerate(bad, start=1):
        publish_state(controller, bridge, states, payload, expect="invalid")
        assert bridge.counts.invalid == n
    assert bridge.counts.applied == 0
    assert Device.objects.values().get(resource=elevator) == before
    assert Resource.objects.get(pk=elevator.pk).in_service


@override_settings(BUILDING_ADAPTER="mqtt")
def test_a_lift_reporting_fire_mode_is_taken_out_of_service(site, prefix, controller, bridge):
    robot = factories.robot_create(site, "R1")
    elevator = Resource.objects.get(site=site, code="ELEV")
    lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="3F")
    states = f"{prefix}/tiny/lift_states/ELEV"

    publish_state(controller, bridge, states, lift_state(current_mode=3), expect="applied")

    elevator.refresh_from_db()
    assert not elevator.in_service
    assert elevator.out_of_service_reason == "ELEV reports a fault: fire"
    assert BoardMessage.objects.pending().filter(
        robot=robot, type=MessageType.RESOURCE_OUT_OF_SERVICE
    )


@override_settings(BUILDING_ADAPTER="mqtt")
def test_it_opens_and_closes_a_door_by_door_requests(site, prefix, controller, bridge):
    robot = factories.robot_create(site, "R1")
    door = Resource.objects.get(site=site, code="DOOR-2F")
    lease_acquire(robot=robot, resource=door, request_id="q-1")
    bridge.publish_pending()
    opened = next_request(controller, f"{prefix}/tiny/door_requests/DOOR-2F")
    assert opened["door_name"] == "DOOR-2F"
    assert opened["requested_mode"] == {"value": 2}
    assert opened["requester_id"] == "hospital_delivery"

    state = {"door_time": {"sec": 0, "nanosec": 0}, "door_name": "DOOR-2F"}
    states = f"{prefix}/tiny/door_states/DOOR-2F"
    publish_state(
        controller, bridge, states, state | {"current_mode": {"value": 2}}, expect="applied"
    )
    assert Device.objects.get(resource=door).door == "open"
    publish_state(
        controller, bridge, states, state | {"current_mode": {"value": 3}}, expect="applied"
    )
    door.refresh_from_db()
    assert door.out_of_service_reason == "DOOR-2F reports a fault: offline"
