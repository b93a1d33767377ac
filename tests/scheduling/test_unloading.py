"""A robot waiting at a drop-off that nobody unloads: operators alerted once, past the timeout."""

from datetime import timedelta

from boards.models import RobotEvent
from robots.models import Alert
from scheduling.services import task_allocate, unload_timeout_sweep
from tests.scheduling.conftest import Beater, event, request


def test_operators_are_alerted_once_when_nobody_unloads_past_the_sites_timeout(r1, site):
    task = request(site, dropoffs=("3F-WARD",), contents="Blood sample")
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0)])
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 1)], **at_ward)
    arrived = RobotEvent.objects.get(type="arrived").received_at
    timeout = timedelta(seconds=site.unload_timeout)

    assert unload_timeout_sweep(now=arrived + timeout - timedelta(seconds=1)) == 0
    assert unload_timeout_sweep(now=arrived + timeout) == 1
    assert unload_timeout_sweep(now=arrived + 2 * timeout) == 0

    alert = Alert.objects.get()
    assert (alert.kind, alert.robot, alert.task) == ("unload_timeout", r1, task.code)
    assert alert.message.startswith(
        f"R1 has waited 5 min at Ward 3 with Blood sample {task.code}: nobody has unloaded it"
    )
    assert "nobody has unloaded it" in task.history.last().note


def test_a_robot_unloaded_in_time_raises_nothing(r1, site):
    task = request(site, dropoffs=("3F-WARD",))
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0)])
    at_ward = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
    beater.beat(events=[event("arrived", task.code, 1)], **at_ward)
    beater.beat(events=[event("unloaded", task.code, 1)], **at_ward)

    arrived = RobotEvent.objects.get(type="arrived").received_at
    assert unload_timeout_sweep(now=arrived + timedelta(hours=1)) == 0
    assert not Alert.objects.exists()
