"""The link's translation, without a broker: orders hold the horizon before every resource, a
grant releases it by an update, and a repeated state applies its events once."""

import pytest
from django.db import transaction

from boards.models import RobotEvent
from scheduling.services.operator import robot_action
from tests.vda5050.conftest import deliver
from vda5050.services import vehicle_heartbeat
from vda5050.validation import validator

pytestmark = pytest.mark.django_db


def state(**changes) -> dict:
    base = {
        "headerId": 0,
        "timestamp": "2026-11-23T10:00:00.000Z",
        "version": "2.0.0",
        "manufacturer": "Acme",
        "serialNumber": "SN-1",
        "orderId": "",
        "orderUpdateId": 0,
        "lastNodeId": "1F-DOCK-1",
        "lastNodeSequenceId": 0,
        "nodeStates": [],
        "edgeStates": [],
        "driving": False,
        "actionStates": [],
        "batteryState": {"batteryCharge": 90.0, "charging": True},
        "operatingMode": "AUTOMATIC",
        "errors": [],
        "safetyState": {"eStop": "NONE", "fieldViolation": False},
    }
    return {**base, **changes}


def exchange(link, vda_state):
    """One state through the link and the board, as the bridge does it; what it publishes,
    but for the stateRequest following each order (test_it_asks_for_the_state_at_once)."""
    return [out for out in exchange_all(link, vda_state) if not state_request(out)]


def exchange_all(link, vda_state):
    messages = vehicle_heartbeat(robot_id=link.robot_id, heartbeat=link.heartbeat(vda_state))
    link.applied()
    return link.messages(messages)


def state_request(out) -> bool:
    actions = out.body.get("actions", [])
    return out.topic == "instantActions" and [a["actionType"] for a in actions] == ["stateRequest"]


def test_it_holds_the_horizon_before_the_elevator_until_the_grant(link, site):
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    assert order.topic == "order"
    body = {**order.body, **state()}  # a header, to check against the schema
    assert not list(validator("order").iter_errors(body))
    nodes = [(n["nodeId"], n["released"]) for n in order.body["nodes"]]
    # Released up to the elevator lobby; the ride, the door and the lab wait for their grants.
    assert nodes[: nodes.index(("1F-ELEV-WAIT", True)) + 1] == [
        ("1F-DOCK-1", True),
        ("1F-HALL", True),
        ("1F-PHARM", True),
        ("1F-HALL", True),
        ("1F-ELEV-WAIT", True),
    ]
    assert all(not released for _, released in nodes[5:])
    assert [e["released"] for e in order.body["edges"] if e.get("edgeDescription")] == [
        False,
        False,
    ]
    pick = order.body["nodes"][2]["actions"][0]
    assert pick["actionType"] == "pick"

    # At the lobby with the sample on board: the bridge asks for the elevator to 2F...
    finished = [{"actionId": pick["actionId"], "actionType": "pick", "actionStatus": "FINISHED"}]
    at_lobby = state(
        orderId=order.body["orderId"],
        lastNodeId="1F-ELEV-WAIT",
        lastNodeSequenceId=8,
        nodeStates=[{"nodeId": "2F-ELEV-WAIT", "sequenceId": 10, "released": False}],
        actionStates=finished,
        loads=[{"loadId": "x"}],
    )
    published = exchange(link, at_lobby)
    assert RobotEvent.objects.filter(type="loaded").count() == 1
    # ...the free elevator is granted in the same heartbeat: an update releases the ride, up to
    # the door's near side (the next resource).
    [update] = published
    assert update.body["orderUpdateId"] == 1
    assert update.body["nodes"][0]["sequenceId"] == 8  # starts where the base ended
    released = [n["nodeId"] for n in update.body["nodes"] if n["released"]]
    assert released == ["1F-ELEV-WAIT", "2F-ELEV-WAIT", "2F-LAB-DOOR-N"]

    # The same state again (QoS 1 delivers twice): nothing new, the loaded event applied once.
    assert exchange(link, at_lobby) == []
    assert RobotEvent.objects.filter(type="loaded").count() == 1


def test_it_pauses_and_resumes_by_instant_actions(link, vehicle, staff):
    exchange(link, state())
    with transaction.atomic():
        robot_action(robot=vehicle, action="pause", by=staff)
    [pause] = exchange(link, state())
    assert pause.topic == "instantActions"
    assert [a["actionType"] for a in pause.body["actions"]] == ["startPause", "stateRequest"]
    exchange(link, state(paused=True))
    vehicle.refresh_from_db()
    assert vehicle.status == "paused"

    with transaction.atomic():
        robot_action(robot=vehicle, action="resume", by=staff)
    [resume] = exchange(link, state(paused=True))
    assert [a["actionType"] for a in resume.body["actions"]] == ["stopPause", "stateRequest"]


def test_it_sends_the_vehicle_home_on_return_to_dock(link, vehicle, site, staff):
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    driving = state(
        orderId=order.body["orderId"],
        lastNodeId="1F-HALL",
        lastNodeSequenceId=2,
        driving=True,
        nodeStates=[{"nodeId": "1F-PHARM", "sequenceId": 4, "released": True}],
    )
    exchange(link, driving)
    with transaction.atomic():
        robot_action(robot=vehicle, action="return_to_dock", by=staff)

    # The operator's command: the vehicle's order is cancelled first...
    [cancel] = exchange(link, driving)
    assert [a["actionType"] for a in cancel.body["actions"]] == ["cancelOrder", "stateRequest"]
    assert exchange(link, driving) == []  # (once)
    # ...and once it reports no nodes left, it is ordered to its dock from where it stopped.
    stopped = {**driving, "lastNodeId": "1F-PHARM", "lastNodeSequenceId": 4, "driving": False}
    [home] = exchange(link, {**stopped, "nodeStates": []})
    assert home.topic == "order"
    assert home.body["orderId"] != order.body["orderId"]
    assert [n["nodeId"] for n in home.body["nodes"]] == ["1F-PHARM", "1F-HALL", "1F-DOCK-1"]
    assert all(n["released"] and not n["actions"] for n in home.body["nodes"])


def pharmacy_state(order, status: str, **changes) -> dict:
    pick = order.body["nodes"][2]["actions"][0]["actionId"]
    action = {"actionId": pick, "actionType": "pick", "actionStatus": status}
    return state(
        orderId=order.body["orderId"],
        lastNodeId="1F-PHARM",
        lastNodeSequenceId=4,
        actionStates=[{**action, "resultDescription": "compartment jammed"}],
        **changes,
    )


def test_it_reports_a_pick_the_vehicle_failed(link, site):
    exchange(link, state())
    task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())

    exchange(link, pharmacy_state(order, "FAILED"))

    event = RobotEvent.objects.get(type="task_failed")
    assert (event.task, event.data["reason"]) == (task.code, "compartment jammed")
    task.refresh_from_db()
    assert task.robot_id is None  # nothing on board: it goes to another robot


def test_it_does_not_report_the_picks_its_own_cancel_order_failed(link, vehicle, site, staff):
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    on_the_way = {"nodeId": "1F-HALL", "sequenceId": 6, "released": True}
    exchange(link, pharmacy_state(order, "WAITING", nodeStates=[on_the_way]))
    with transaction.atomic():
        robot_action(robot=vehicle, action="return_to_dock", by=staff)
    [cancel] = exchange(link, pharmacy_state(order, "WAITING", nodeStates=[on_the_way]))
    assert [a["actionType"] for a in cancel.body["actions"]] == ["cancelOrder", "stateRequest"]

    # The standard's vehicle fails the actions a cancelled order had not started.
    exchange(link, pharmacy_state(order, "FAILED"))

    assert not RobotEvent.objects.filter(type="task_failed").exists()


def test_it_changes_the_route_only_after_the_staff_are_done(link, site):
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    ahead = [{"nodeId": "1F-HALL", "sequenceId": 6, "released": True}]
    loading = pharmacy_state(order, "RUNNING", nodeStates=ahead)
    exchange(link, loading)

    deliver(site, ["1F-PHARM"], ["3F-WARD"])  # a new plan for the vehicle, mid-loading

    assert exchange(link, loading) == []  # a cancelOrder now would interrupt the staff
    [cancel] = exchange(link, pharmacy_state(order, "FINISHED", nodeStates=ahead))
    assert [a["actionType"] for a in cancel.body["actions"]] == ["cancelOrder", "stateRequest"]
    [new] = exchange(link, pharmacy_state(order, "FINISHED"))
    assert new.topic == "order"
    assert new.body["nodes"][0]["nodeId"] == "1F-PHARM"
    picks = [a for n in new.body["nodes"] for a in n["actions"] if a["actionType"] == "pick"]
    assert len(picks) == 1  # the second delivery's; the first one's pick is done
