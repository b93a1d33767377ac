"""One VDA 5050 vehicle carries a delivery across floors, through the elevator and the door,
with the bridge running in this process and the vehicle simulated over the real broker."""

import pytest

from boards.models import RobotEvent
from resources.models import Lease
from robots.models import Robot
from scheduling.models import Task, TaskTransition
from tests import servers
from tests.vda5050.conftest import (
    BROKER,
    SimBuilding,
    Spy,
    deliver,
    vda_robot_create,
    vehicle_start,
)
from vda5050.bridge import Bridge

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


def test_it_delivers_through_the_elevator_and_the_door(site, bridge, interface):
    robot = vda_robot_create(site, "V1", "SN-1")
    with Spy(interface) as spy:
        vehicle = vehicle_start(robot, interface)
        try:
            servers.poll(
                lambda: robot.__class__.objects.get(pk=robot.pk).presence == "online",
                timeout=10,
                what="the vehicle online",
            )
            task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
            servers.poll(
                lambda: Task.objects.get(pk=task.pk).status == "completed",
                timeout=60,
                interval=0.2,
                what="the delivery completed",
            )
            servers.poll(lambda: vehicle.idle_at_dock, timeout=60, what="the vehicle home")
        finally:
            vehicle.stop()
    moves = TaskTransition.objects.filter(task=task).exclude(old="").values_list("old", "new")
    changes = [new for old, new in moves if old != new]
    for status in ("acknowledged", "picked_up", "delivered", "completed"):
        assert changes.count(status) == 1, moves
    events = list(RobotEvent.objects.filter(robot=robot).values_list("type", flat=True))
    assert events.count("loaded") == 1
    assert events.count("unloaded") == 1
    rides = Lease.objects.filter(robot=robot, resource__code="ELEV", entered_at__isnull=False)
    assert rides.count() == 2  # up to the lab and back down to the dock
    assert Lease.objects.filter(robot=robot, resource__code="DOOR-2F").count() == 2
    assert not Lease.objects.live().exists()
    orders = [body for _, body in spy.of("order")]
    assert orders, "no order was published"


def test_it_carries_on_when_the_bridge_restarts_mid_delivery(site, transactional_db, interface):
    robot = vda_robot_create(site, "V1", "SN-1")
    first = Bridge(host=BROKER[0], port=BROKER[1], interface=interface)
    first.start()
    building = SimBuilding().__enter__()
    # Slower than the other tests: the bridge restarts while the vehicle is on the pharmacy's
    # floor, on its way to the elevator (20 simulated seconds: 2 s here).
    vehicle = vehicle_start(robot, interface, speedup=10)
    second = None
    try:
        servers.poll(lambda: Robot.objects.get(pk=robot.pk).presence == "online", what="online")
        task = deliver(site, ["1F-PHARM"], ["2F-LAB"])
        servers.poll(
            lambda: Task.objects.get(pk=task.pk).status == "picked_up",
            timeout=30,
            what="the sample on board",
        )
        first.stop()
        second = Bridge(host=BROKER[0], port=BROKER[1], interface=interface)
        second.start()  # knows nothing of the vehicle's order: cancels it, orders the plan again
        servers.poll(
            lambda: Task.objects.get(pk=task.pk).status == "completed",
            timeout=60,
            interval=0.2,
            what="the delivery completed",
        )
        servers.poll(lambda: vehicle.idle_at_dock, timeout=60, what="the vehicle home")
    finally:
        vehicle.stop()
        if second is not None:
            second.stop()
        building.__exit__()
    assert any(
        action["actionType"] == "cancelOrder" for order in vehicle.instant for action in order
    )
    loaded = RobotEvent.objects.filter(robot=robot, type="loaded")
    assert loaded.count() == 1  # the pick is not made again
    assert not Lease.objects.live().exists()
