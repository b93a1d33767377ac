"""One VDA 5050 vehicle carries a delivery across floors, through the elevator and the door,
with the bridge running in this process and the vehicle simulated over the real broker."""

import pytest

from boards.models import RobotEvent
from resources.models import Lease
from scheduling.models import Task, TaskTransition
from tests import servers
from tests.vda5050.conftest import Spy, deliver, vda_robot_create, vehicle_start

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
