"""A vehicle's factsheet (2.0): asked for once, stored, and every order checked against it
before it is sent; an order the vehicle could not do is refused on our side with one alert.
And the operators' side of a refusal and of a lift whose car never comes: one alert each."""

import json
from datetime import timedelta

import pytest
from django.utils import timezone

from boards.models import RobotEvent
from building.services import sim_sweep
from robots.models import Alert, Robot
from scheduling.models import Task
from tests import servers
from tests.vda5050.conftest import deliver, vda_robot_create, vehicle_start
from tests.vda5050.test_field_vehicles import link_for, parameters, refusal
from tests.vda5050.test_link import exchange, state
from tests.vda5050.test_quiet_vehicles import IDENTITY, Recording

pytestmark = pytest.mark.django_db


def factsheet(*actions: str, **changes) -> dict:
    listed = [
        {
            "actionType": kind,
            "actionScopes": ["NODE"],
            "actionParameters": [{"key": "loadType", "isOptional": False}],
        }
        for kind in actions
    ]
    return {
        "headerId": 0,
        "timestamp": "2026-11-23T10:00:00.000Z",
        "version": "2.0.0",
        "manufacturer": "Acme",
        "serialNumber": "SN-1",
        "physicalParameters": {"speedMin": 0.0, "speedMax": 1.2},
        "protocolFeatures": {"optionalParameters": [], "agvActions": listed},
        **changes,
    }


def instant_kinds(bridge) -> list[list[str]]:
    return [
        [a["actionType"] for a in out.body["actions"]]
        for out in bridge.published
        if out.topic == "instantActions"
    ]


def test_it_asks_for_the_factsheet_once_and_stores_it(vehicle):
    bridge = Recording()
    link = bridge._link(IDENTITY)
    bridge._connection(link, IDENTITY, {"connectionState": "ONLINE"})
    bridge._state(link, IDENTITY, state(headerId=1))
    bridge._state(link, IDENTITY, state(headerId=2))
    assert instant_kinds(bridge).count(["factsheetRequest"]) == 1

    sheet = factsheet("pick", "drop")
    bridge._handle(
        ["unused", "v2", "Acme", "SN-1", "factsheet"], "factsheet", json.dumps(sheet).encode()
    )
    assert Robot.objects.get(pk=vehicle.pk).vda5050_factsheet == sheet
    assert link.factsheet == sheet
    # A restarted bridge knows it before the vehicle says it again, and does not ask.
    again = Recording()
    relinked = again._link(IDENTITY)
    again._state(relinked, IDENTITY, state(headerId=3))
    assert relinked.factsheet == sheet
    assert ["factsheetRequest"] not in instant_kinds(again)


def test_it_refuses_an_order_the_factsheet_says_the_vehicle_cannot_do(vehicle, site):
    link = link_for(vehicle)
    link.factsheet_seen(factsheet("drop"))  # no pick
    exchange(link, state())
    task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
    assert Task.objects.get(pk=task.pk).robot_id == vehicle.pk
    assert exchange(link, state()) == []  # never sent
    sent = exchange(link, state()) + exchange(link, state())  # the task_failed, then its replan
    assert not [out for out in sent if out.topic == "order" and parameters(out, "pick")]

    [event] = RobotEvent.objects.filter(type="task_failed")
    assert "not sent" in event.data["reason"]
    assert Task.objects.get(pk=task.pk).robot_id is None  # back to allocation
    [alert] = Alert.objects.filter(kind="task_failed")
    assert "V1" in alert.message
    assert "its factsheet lists no action 'pick'" in alert.message


def test_it_refuses_an_order_missing_a_parameter_the_vehicle_requires(vehicle, site):
    link = link_for(vehicle)
    required = factsheet("pick", "drop")
    required["protocolFeatures"]["agvActions"][0]["actionParameters"].append(
        {"key": "lhd", "isOptional": False}
    )
    link.factsheet_seen(required)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    assert exchange(link, state()) == []
    exchange(link, state())
    [alert] = Alert.objects.filter(kind="task_failed")
    assert "'pick' needs the parameter 'lhd'" in alert.message


def test_it_sends_an_order_the_factsheet_allows_and_one_to_a_vehicle_without_a_list(vehicle, site):
    link = link_for(vehicle)
    link.factsheet_seen(factsheet("pick", "drop"))
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    assert parameters(order, "pick")
    # vda-5050-lib's virtual vehicle answers with its header only: nothing to check against.
    bare = link_for(vehicle)
    bare.factsheet_seen({k: v for k, v in factsheet().items() if k != "protocolFeatures"})
    sent = exchange(bare, state()) + exchange(bare, state())
    [order] = [out for out in sent if out.topic == "order"]
    assert parameters(order, "pick")


def test_it_raises_one_alert_for_an_order_of_two_tasks_the_vehicle_refused(vehicle, site):
    link = link_for(vehicle)
    exchange(link, state())
    first = deliver(site, ["1F-PHARM"], ["2F-LAB"])
    second = deliver(site, ["1F-PHARM"], ["3F-WARD"])
    [order] = exchange(link, state())  # the newer plan, both tasks in one order
    assert len(parameters(order, "pick")) == 2
    refused = state(errors=[refusal(order, "orderError", "invalid actionParameter loadType")])
    exchange(link, refused)
    exchange(link, refused)

    assert RobotEvent.objects.filter(type="task_failed").count() == 2
    tasks = Task.objects.filter(pk__in=[first.pk, second.pk])
    assert set(tasks.values_list("robot", flat=True)) == {None}
    [alert] = Alert.objects.filter(kind="task_failed")
    assert first.code in alert.message
    assert second.code in alert.message
    assert "orderError: invalid actionParameter loadType" in alert.message


def test_it_alerts_once_when_the_car_does_not_come_and_keeps_the_vehicle_held(site):
    robot = vda_robot_create(site, "V1", "SN-1")
    robot.vda5050 = {"lift_wait_alert": 45}
    robot.save(update_fields=["vda5050"])
    bridge = Recording()  # no building sweep runs: the car is never at the floor
    link = bridge._link(IDENTITY)
    bridge._connection(link, IDENTITY, {"connectionState": "ONLINE"})
    bridge._state(link, IDENTITY, state(headerId=1))
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    bridge._state(link, IDENTITY, state(headerId=2))
    order = link.order
    crossing = order.crossings[0]
    assert crossing.car_seq is not None  # ridden by the car

    def at_lobby(header: int, at: float) -> None:
        bridge.now = at
        lobby = state(
            headerId=header,
            orderId=order.order_id,
            lastNodeId="1F-ELEV-WAIT",
            lastNodeSequenceId=crossing.wait_seq,
        )
        bridge._state(link, IDENTITY, lobby)

    at_lobby(3, 1001.0)  # asks for the lift
    at_lobby(4, 1002.0)  # granted, the car called
    assert crossing.granted
    at_lobby(5, 1002.0 + 40)
    assert not Alert.objects.filter(kind="lift_car_missing").exists()
    at_lobby(6, 1002.0 + 45)
    at_lobby(7, 1002.0 + 200)
    [alert] = Alert.objects.filter(kind="lift_car_missing")
    assert alert.robot_id == robot.pk
    assert "V1 has waited" in alert.message
    assert "at ELEV on floor 1F" in alert.message
    assert order.released_until == crossing.wait_seq  # held: the way into the car not released
    released = [
        node["sequenceId"]
        for out in bridge.published
        if out.topic == "order"
        for node in out.body["nodes"]
        if node["released"]
    ]
    assert max(released) == crossing.wait_seq
    assert Robot.objects.get(pk=robot.pk).status == "waiting_resource"
    # The car comes after all (the building's sweep, late): the vehicle is let in, the alert
    # closes by itself.
    sim_sweep(now=timezone.now() + timedelta(seconds=60))
    at_lobby(8, 1002.0 + 201)
    assert crossing.car_here
    assert order.released_until == crossing.car_seq
    assert Alert.objects.open().filter(kind="lift_car_missing").count() == 0


@pytest.mark.django_db(transaction=True)
def test_our_simulated_vehicle_publishes_its_factsheet_and_an_order_it_cannot_do_stays_here(
    site, bridge, interface
):
    robot = vda_robot_create(site, "V1", "SN-1")
    no_drop = ("pick", "startPause", "stopPause", "cancelOrder", "stateRequest")
    vehicle = vehicle_start(robot, interface, actions=no_drop)
    try:
        servers.poll(
            lambda: Robot.objects.get(pk=robot.pk).vda5050_factsheet, what="its factsheet stored"
        )
        sheet = Robot.objects.get(pk=robot.pk).vda5050_factsheet
        listed = [a["actionType"] for a in sheet["protocolFeatures"]["agvActions"]]
        assert listed == list(no_drop)
        servers.poll(lambda: Robot.objects.get(pk=robot.pk).presence == "online", what="online")
        task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
        servers.poll(
            lambda: Alert.objects.filter(kind="task_failed").exists(), what="the refusal alert"
        )
    finally:
        vehicle.stop()
    assert Task.objects.get(pk=task.pk).robot_id is None
    assert "its factsheet lists no action 'drop'" in Alert.objects.get(kind="task_failed").message
    assert not [o for o in vehicle.orders if any(n["actions"] for n in o["nodes"])]
