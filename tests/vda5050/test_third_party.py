"""Vehicles no one here wrote: vda-5050-lib's virtual 2.0 vehicles (tests/vda_5050_lib.py) on
the tiny site, through its elevator, door and corridor, with the bridge in this process over
the real broker. The site file gives them what they need (LIB_OPTIONS): their pick and drop
parameters and their two quirks."""

import copy
import time

import pytest
from django.db import transaction

from boards.models import BoardMessage, RobotEvent
from resources.models import Lease
from robots.models import Alert, PresenceChange, Robot
from robots.services import presence_sweep
from scheduling.models import Task, TaskTransition
from scheduling.services.allocation import site_allocate_due
from scheduling.services.operator import robot_action
from tests import factories, servers
from tests.vda5050.conftest import BROKER, Spy, deliver, vda_robot_create, vehicle_start
from tests.vda_5050_lib import LIB_OPTIONS, LibVehicle, LibVehicles

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]

# Three across floors, one on the ground floor (its second station, added below).
DELIVERIES = [
    (["1F-PHARM"], ["2F-LAB"]),
    (["2F-LAB"], ["3F-WARD"]),
    (["3F-WARD"], ["1F-PHARM"]),
    (["1F-PHARM"], ["1F-CT"]),
]


@pytest.fixture
def site(db):
    floors = copy.deepcopy(factories.TINY_SITE["floors"])
    ground = floors[0]
    ground["waypoints"].append({"code": "1F-CT", "x": 10, "y": -10, "kind": "station"})
    ground["edges"].append(["1F-HALL", "1F-CT"])
    resources = copy.deepcopy(factories.TINY_SITE["resources"])
    resources[0]["seconds_per_floor"] = 1  # the simulated car's quickest
    return factories.site_create(floors=floors, resources=resources)


def lib_robot(site, code: str, serial: str, dock: str, **options) -> Robot:
    robot = vda_robot_create(site, code, serial, dock=dock)
    robot.capacity = 1  # the library's virtual vehicle carries one load at a time
    robot.vda5050 = {**LIB_OPTIONS, **options}
    robot.save(update_fields=["capacity", "vda5050"])
    return robot


def online(*robots: Robot) -> bool:
    return all(Robot.objects.get(pk=r.pk).presence == "online" for r in robots)


def home(*robots: Robot) -> bool:
    rows = Robot.objects.filter(pk__in=[r.pk for r in robots]).select_related("waypoint")
    at_dock = all(r.waypoint_id == r.dock_id and r.status in ("idle", "charging") for r in rows)
    return at_dock and not Lease.objects.live().exists()


def car_releases(orders) -> list[tuple[float, str, str]]:
    """(when, vehicle, floor) of each first release of a way into a lift's car (the floor it
    is entered on) or out of it (the floor it is left on), from the orders published."""
    seen, releases = set(), []
    for at, order in orders:
        nodes = order["nodes"]
        for a, b in zip(nodes, nodes[1:], strict=False):
            car = a if a["nodeId"].endswith("-CAR") else b if b["nodeId"].endswith("-CAR") else None
            key = (order["orderId"], b["sequenceId"])
            if car is None or not b["released"] or key in seen:
                continue
            seen.add(key)
            floor = car["nodePosition"]["mapId"] if b is car else b["nodePosition"]["mapId"]
            releases.append((at, order["serialNumber"], floor))
    return releases


def car_reported_before(robot_serials: dict, at: float, serial: str, floor: str) -> bool:
    reports = BoardMessage.objects.filter(
        robot__code=robot_serials[serial], type="elevator_at_floor", body__floor=floor
    )
    return any(report.posted_at.timestamp() <= at for report in reports)


def vehicle_paused(spy, serial: str, *, since: float) -> bool | None:
    """`paused` in the vehicle's last state published after `since`, None if none was."""
    states = [
        body for at, body in spy.of("state") if at >= since and body["serialNumber"] == serial
    ]
    return states[-1]["paused"] if states else None


def test_it_delivers_across_floors_with_two_third_party_vehicles(site, bridge, interface, staff):
    robots = [
        lib_robot(site, "V1", "SN-1", "1F-DOCK-1"),
        lib_robot(site, "V2", "SN-2", "1F-DOCK-2"),
    ]
    # One at the library's default interval (a state every 30 s when nothing happens), one
    # at a short one.
    vehicles = [LibVehicle(robots[0], state_interval=30), LibVehicle(robots[1], state_interval=2)]
    with Spy(interface) as spy, LibVehicles(vehicles, broker=BROKER, interface=interface):
        servers.poll(lambda: online(*robots), timeout=20, what="both vehicles online")
        tasks = [deliver(site, pickups, dropoffs) for pickups, dropoffs in DELIVERIES]

        def all_completed():
            site_allocate_due(site_id=site.pk)  # the allocation cycle Celery beat runs
            presence_sweep()  # and the presence sweep
            statuses = set(
                Task.objects.filter(pk__in=[t.pk for t in tasks]).values_list("status", flat=True)
            )
            return statuses == {"completed"}

        servers.poll(all_completed, timeout=240, interval=0.5, what="every delivery completed")
        servers.poll(lambda: home(*robots), timeout=60, interval=0.5, what="both vehicles home")
        presence_sweep()
        # An operator pauses and resumes the quiet one (30 s states): it obeys within 2 s.
        for action, paused in (("pause", True), ("resume", False)):
            pressed = time.time()
            with transaction.atomic():
                robot_action(robot=robots[0], action=action, by=staff)
            servers.poll(
                lambda p=paused, t=pressed: vehicle_paused(spy, "SN-1", since=t) is p,
                timeout=2,
                what=f"{action} obeyed",
            )
        # Checked while both are still connected: leaving, each says it goes offline.
        flips = PresenceChange.objects.filter(robot__in=robots).exclude(new="online")
        assert not flips.exists()  # never unreachable, the quiet one neither
    # Asked for its factsheet, the library's vehicle publishes one with its header only:
    # stored, and nothing in it to hold an order against.
    for robot in Robot.objects.filter(pk__in=[r.pk for r in robots]):
        assert robot.vda5050_factsheet["serialNumber"] == robot.serial_number
        assert "protocolFeatures" not in robot.vda5050_factsheet
    for task in tasks:
        moves = TaskTransition.objects.filter(task=task).exclude(old="").values_list("old", "new")
        changes = [new for old, new in moves if old != new]
        for status in ("picked_up", "delivered", "completed"):
            assert changes.count(status) == 1, (task.code, list(moves))
    assert RobotEvent.objects.filter(type="loaded").count() == 4
    assert RobotEvent.objects.filter(type="unloaded").count() == 4
    assert not Alert.objects.filter(kind="task_failed").exists()
    # Into a lift's car only once the building reported it at the vehicle's floor, out of it
    # only once it reported the destination: every release published after that report.
    releases = car_releases(spy.of("order"))
    serials = {r.serial_number: r.code for r in robots}
    assert len(releases) >= 6  # three deliveries across floors: in and out of each ride
    for at, serial, floor in releases:
        assert car_reported_before(serials, at, serial, floor), (serial, floor)
    rides = Lease.objects.filter(resource__code="ELEV", entered_at__isnull=False)
    assert rides.count() >= 3
    orders = [body for _, body in spy.of("order")]
    picks = [
        action
        for order in orders
        for node in order["nodes"]
        for action in node["actions"]
        if action["actionType"] == "pick"
    ]
    assert picks
    assert all(
        {p["key"]: p["value"] for p in a["actionParameters"]}
        == {"stationType": "floor", "loadType": "EPAL"}
        for a in picks
    )


def test_it_gives_a_delivery_the_vehicle_refused_to_another(site, bridge, interface):
    # Without the library's loadType (EPAL), its vehicle refuses every pick: orderError.
    refuser = lib_robot(site, "V1", "SN-1", "1F-DOCK-1", pick={}, drop={})
    other = vda_robot_create(site, "V2", "SN-2", dock="1F-DOCK-2")
    with LibVehicles([LibVehicle(refuser, state_interval=30)], broker=BROKER, interface=interface):
        servers.poll(lambda: online(refuser), timeout=20, what="the vehicle online")
        task = deliver(site, ["1F-PHARM"], ["1F-CT"])
        assert Task.objects.get(pk=task.pk).robot_id == refuser.pk
        servers.poll(
            lambda: RobotEvent.objects.filter(robot=refuser, type="task_failed").exists(),
            timeout=15,
            what="the refusal seen",
        )
        assert Task.objects.get(pk=task.pk).robot_id is None
        [alert] = Alert.objects.filter(robot=refuser)
        assert "orderError" in alert.message
        assert "invalid actionParameter" in alert.message
        vehicle = vehicle_start(other, interface)
        try:
            servers.poll(lambda: online(other), timeout=20, what="the other vehicle online")
            assert site_allocate_due(site_id=site.pk) == 1  # one allocation cycle
            assert Task.objects.get(pk=task.pk).robot_id == other.pk
            servers.poll(
                lambda: Task.objects.get(pk=task.pk).status == "completed",
                timeout=60,
                interval=0.2,
                what="the delivery completed",
            )
        finally:
            vehicle.stop()
