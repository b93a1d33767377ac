"""What 2.0 vehicles in the field need of the link, without a broker: pick and drop parameters
from the site file, a stateRequest after each order, refusals taken back, a new order from
where a cancel stopped the vehicle, lifts entered only with the car there, and quirks."""

import pytest

from boards.models import RobotEvent
from robots.mapcache import router_for, site_map
from robots.models import Alert
from tests.vda5050.conftest import deliver
from tests.vda5050.test_link import exchange, exchange_all, state, state_request
from vda5050.link import Link
from vda5050.orders import VehicleOptions

pytestmark = pytest.mark.django_db


def link_for(vehicle, **options) -> Link:
    return Link(
        robot_id=vehicle.pk,
        robot_code=vehicle.code,
        dock=vehicle.dock.code,
        site_map=site_map(vehicle.site),
        router=router_for(vehicle.site),
        **options,
    )


def parameters(order, kind: str) -> list[dict]:
    actions = [a for n in order.body["nodes"] for a in n["actions"] if a["actionType"] == kind]
    return [{p["key"]: p["value"] for p in a["actionParameters"]} for a in actions]


def test_it_gives_pick_and_drop_the_parameters_the_site_file_names(vehicle, site):
    options = VehicleOptions.from_site(
        {
            "pick": {"loadType": "EPAL"},
            "stations": {"2F-LAB": {"drop": {"stationType": "floor-lab", "lhd": "arm"}}},
        }
    )
    link = link_for(vehicle, options=options)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    # The vehicle's own values, then the station's, over 2.0's two listed keys' defaults.
    assert parameters(order, "pick") == [{"stationType": "floor", "loadType": "EPAL"}]
    assert parameters(order, "drop") == [
        {"stationType": "floor-lab", "loadType": "tote", "lhd": "arm"}
    ]
    positions = [n["nodePosition"] for n in order.body["nodes"]]
    assert all(p["allowedDeviationXy"] == 0.5 for p in positions)


def test_it_asks_for_the_state_at_once_after_an_order(vehicle, site):
    link = link_for(vehicle)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    order, ask = exchange_all(link, state())
    assert order.topic == "order"
    assert state_request(ask)


def refusal(order, error_type: str, words: str) -> dict:
    return {
        "errorType": error_type,
        "errorLevel": "WARNING",
        "errorDescription": words,
        "errorReferences": [
            {"referenceKey": "topic", "referenceValue": "order"},
            {"referenceKey": "orderId", "referenceValue": order.body["orderId"]},
        ],
    }


def test_it_gives_back_the_tasks_of_an_order_the_vehicle_refused(vehicle, site):
    link = link_for(vehicle)
    exchange(link, state())
    task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    words = "order action is not executable: invalid actionParameter"
    refused = state(errors=[refusal(order, "orderError", words)])

    exchange(link, refused)
    exchange(link, refused)  # states repeat their errors: taken back once

    [event] = RobotEvent.objects.filter(type="task_failed")
    assert words in event.data["reason"]
    task.refresh_from_db()
    assert task.robot_id is None  # to allocation again, never to this vehicle for it
    [alert] = Alert.objects.filter(task=task.code)
    assert "V1" in alert.message
    assert words in alert.message


def test_it_ignores_an_error_about_another_order(vehicle, site):
    link = link_for(vehicle)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    other = refusal(order, "noRouteError", "no route")
    other["errorReferences"][1]["referenceValue"] = "someone-elses"
    exchange(link, state(errors=[other]))
    assert not RobotEvent.objects.filter(type="task_failed").exists()


def test_it_starts_a_new_order_where_a_cancel_stopped_the_vehicle(vehicle, site):
    link = link_for(vehicle)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    deliver(site, ["1F-PHARM"], ["3F-WARD"])  # a new plan: cancel, then order again
    between = {"x": 6.0, "y": 0.0, "theta": 0.0, "mapId": "1F", "positionInitialized": True}
    driving = state(
        orderId=order.body["orderId"],
        lastNodeId="1F-DOCK-1",
        lastNodeSequenceId=0,
        driving=True,
        agvPosition=between,
        nodeStates=[{"nodeId": "1F-HALL", "sequenceId": 2, "released": True}],
    )
    [cancel] = exchange(link, driving)
    assert cancel.topic == "instantActions"
    # 2.0 lets a vehicle stop between two nodes: six metres past its last node, beyond the
    # deviation range, the new order starts where it stands and drives back onto the map.
    stopped = {**driving, "driving": False, "nodeStates": [], "edgeStates": []}
    [new] = exchange(link, stopped)
    first, second = new.body["nodes"][:2]
    assert first["nodePosition"]["x"] == 6.0
    assert first["nodePosition"]["mapId"] == "1F"
    assert second["nodeId"] == "1F-DOCK-1"
    assert new.body["edges"][0]["startNodeId"] == first["nodeId"]


def test_it_lets_the_vehicle_into_the_lift_only_when_the_car_is_there(vehicle, site):
    link = link_for(vehicle, lifts_by_car=True)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    ids = [n["nodeId"] for n in order.body["nodes"]]
    car = ids.index("ELEV-CAR")
    assert ids[car - 1 : car + 2] == ["1F-ELEV-WAIT", "ELEV-CAR", "2F-ELEV-WAIT"]
    crossing = link.order.crossings[0]
    at_lobby = state(
        orderId=order.body["orderId"],
        lastNodeId="1F-ELEV-WAIT",
        lastNodeSequenceId=crossing.wait_seq,
    )
    link.heartbeat(at_lobby)  # the bridge asks for the lift
    link.applied()

    def board(*messages):
        return [out for out in link.messages(list(messages)) if not state_request(out)]

    grant = {"id": "m-1", "type": "resource_grant", "request": crossing.request_id}
    assert board({**grant, "resource": "ELEV"}) == []  # granted: the car is on its way
    assert link.order.released_until == crossing.wait_seq

    car_at = {"id": "m-2", "type": "elevator_at_floor", "resource": "ELEV", "floor": "1F"}
    [into_car] = board(car_at)
    released = [n["nodeId"] for n in into_car.body["nodes"] if n["released"]]
    assert released == ["1F-ELEV-WAIT", "ELEV-CAR"]  # in, and no further

    in_car = state(
        orderId=order.body["orderId"], lastNodeId="ELEV-CAR", lastNodeSequenceId=crossing.car_seq
    )
    beat = link.heartbeat(in_car)
    link.applied()
    assert [e["type"] for e in beat["events"]] == ["resource_entered"]
    assert beat["state"]["status"] == "in_resource"
    assert board({**car_at, "id": "m-3"}) == []  # the car still at 1F: it stays in
    # A fire alarm tells it to get out where the car stands: the bridge has no order for that,
    # so it acks the message and the vehicle stays in the car until the all-clear sends the car
    # on to 2F (docs/integrators/vda5050.md, "Fire alarms").
    told = {"id": "m-5", "type": "elevator_exit", "resource": "ELEV", "floor": "1F"}
    assert board({**told, "lease": "L-1", "waypoint": "1F-ELEV-WAIT", "reason": "fire"}) == []
    assert "m-5" in link.acks
    [out] = board({**car_at, "id": "m-4", "floor": "2F"})
    released = [n["nodeId"] for n in out.body["nodes"] if n["released"]]
    assert released[:3] == ["ELEV-CAR", "2F-ELEV-WAIT", "2F-LAB-DOOR-N"]


def test_it_names_the_instant_actions_list_as_a_quirky_vehicle_wants(vehicle):
    quirky = link_for(
        vehicle, options=VehicleOptions.from_site({"quirks": ["instant_actions_field"]})
    )
    assert list(quirky.instant_actions("stateRequest").body) == ["instantActions"]
    assert list(link_for(vehicle).instant_actions("stateRequest").body) == ["actions"]


def test_it_tells_a_quirky_vehicle_its_map_after_a_lift_ride(vehicle, site):
    options = VehicleOptions.from_site({"quirks": ["init_position_after_lift"]})
    link = link_for(vehicle, options=options)
    exchange(link, state())
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [order] = exchange(link, state())
    [exit_node] = [n for n in order.body["nodes"] if n["nodeId"] == "2F-ELEV-WAIT"]
    [init] = exit_node["actions"]
    values = {p["key"]: p["value"] for p in init["actionParameters"]}
    assert init["actionType"] == "initPosition"
    assert (values["mapId"], values["lastNodeId"]) == ("2F", "2F-ELEV-WAIT")
    assert values["lastNodeSequenceId"] == exit_node["sequenceId"]
