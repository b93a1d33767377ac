"""A VDA 5050 vehicle that drops off the network, and messages the bridge must refuse."""

import json
from datetime import timedelta

import pytest
from prometheus_client import REGISTRY

from boards.models import RobotEvent
from robots.mapcache import site_map
from robots.models import PresenceChange, Robot, RobotBoot
from robots.services import presence_sweep
from robotsim.vda5050 import VdaVehicle
from scheduling.models import Task
from tests import servers
from tests.vda5050.conftest import (
    deliver,
    publish,
    vda_robot_create,
    vehicle_start,
)

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


def rejected(reason: str, topic: str = "state") -> float:
    labels = {"topic": topic, "reason": reason}
    return REGISTRY.get_sample_value("hd_vda5050_messages_rejected_total", labels) or 0.0


def test_it_gives_back_the_tasks_of_a_vehicle_whose_connection_broke(site, bridge, interface):
    robot = vda_robot_create(site, "V1", "SN-1")
    # The staff never come: it waits at the pick-up with nothing on board.
    vehicle = vehicle_start(robot, interface, staff_delay=(10_000.0, 10_000.0))
    servers.poll(lambda: Robot.objects.get(pk=robot.pk).presence == "online", what="online")
    task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
    servers.poll(
        lambda: Robot.objects.get(pk=robot.pk).status == "waiting_load",
        timeout=30,
        what="the vehicle at the pick-up",
    )
    assert Task.objects.get(pk=task.pk).robot_id == robot.pk

    vehicle.break_connection()  # no goodbye: the broker publishes its last will

    servers.poll(
        lambda: Robot.objects.get(pk=robot.pk).presence == "unreachable",
        timeout=20,
        what="the last will applied",
    )
    # Unreachable, as a heartbeat robot that went quiet: it keeps its task for now.
    assert Task.objects.get(pk=task.pk).robot_id == robot.pk
    change = PresenceChange.objects.filter(robot=robot).first()
    assert (change.new, change.cause) == ("unreachable", "connection")

    robot.refresh_from_db()
    presence_sweep(now=robot.offline_at + timedelta(seconds=1))

    robot.refresh_from_db()
    assert robot.presence == "offline"
    task.refresh_from_db()
    assert task.robot_id is None, task.status  # given back, as for a heartbeat robot


def valid_state(robot: Robot, **changes) -> dict:
    vehicle = VdaVehicle(
        site_map=site_map(robot.site),
        manufacturer=robot.manufacturer,
        serial_number=robot.serial_number,
        dock=robot.dock.code,
    )
    return {**vehicle.state(), **changes}


def test_it_drops_malformed_messages_and_counts_them(site, bridge, interface):
    quiet = vda_robot_create(site, "V1", "SN-1")
    witness = vda_robot_create(site, "V2", "SN-2", dock="1F-DOCK-2")
    reasons = ["invalid_json", "schema", "unknown_vehicle", "identity", "refused"]
    before = {reason: rejected(reason) for reason in reasons}

    publish(interface, "SN-1", "state", b"{not json")
    state = valid_state(quiet)
    del state["batteryState"]
    publish(interface, "SN-1", "state", json.dumps(state))
    publish(interface, "SN-1", "state", json.dumps({**valid_state(quiet), "driving": "yes"}))
    publish(interface, "SN-9", "state", json.dumps(valid_state(quiet, serialNumber="SN-9")))
    publish(interface, "SN-1", "state", json.dumps(valid_state(witness)))  # another's identity
    off_map = valid_state(quiet, lastNodeId="NOWHERE")
    off_map["agvPosition"]["mapId"] = "9F"  # well-formed, but no such floor: refused
    publish(interface, "SN-1", "state", json.dumps(off_map))
    publish(interface, "SN-1", "connection", b'{"connectionState": "CONNECTIONBROKEN"}')
    # Then a good one from another vehicle: once it is applied, the bad ones were handled.
    publish(interface, "SN-2", "state", json.dumps(valid_state(witness)))

    servers.poll(lambda: Robot.objects.get(pk=witness.pk).presence == "online", what="witness")
    quiet.refresh_from_db()
    assert quiet.last_seen_at is None
    assert quiet.status == "unknown"
    assert quiet.presence == "offline"
    assert not RobotBoot.objects.filter(robot=quiet).exists()
    assert not PresenceChange.objects.filter(robot=quiet).exists()
    assert not RobotEvent.objects.exists()
    counted = {reason: rejected(reason) - before[reason] for reason in reasons}
    assert counted == {
        "invalid_json": 1,
        "schema": 2,
        "unknown_vehicle": 1,
        "identity": 1,
        "refused": 1,
    }
    assert rejected("schema", topic="connection") >= 1
