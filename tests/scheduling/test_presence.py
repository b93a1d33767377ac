"""A robot that goes offline gives back what it has not picked up; the rest stays with it."""

from datetime import timedelta

from robots.models import Alert, Robot
from robots.services import presence_sweep
from scheduling.services import task_allocate
from tests.scheduling.conftest import Beater, event, pending_plans, request, robot_ready, status


def held_by(robot, site, **fields):
    task = request(site, **fields)
    assert task_allocate(task_id=task.pk)
    task.refresh_from_db()
    assert task.robot == robot
    return task


def offline_time(robot) -> timedelta:
    robot.refresh_from_db()
    return robot.offline_at + timedelta(milliseconds=1)


def test_an_offline_robots_tasks_not_picked_up_are_allocated_again(
    r1, r2, site, enqueued, django_capture_on_commit_callbacks
):
    Robot.objects.filter(pk=r2.pk).update(presence="offline")
    waiting, loaded = (
        held_by(r1, site),
        held_by(r1, site, pickups=("2F-LAB",), dropoffs=("3F-WARD",)),
    )
    beater = Beater(r1)
    beater.ack_all(beater.beat())
    beater.beat(floor="2F", waypoint="2F-LAB", events=[event("loaded", loaded.code, 0)])
    robot_ready(r2)  # R2 comes online, and stays online past R1's offline time

    with django_capture_on_commit_callbacks(execute=True):
        assert presence_sweep(now=offline_time(r1)) == 1

    assert status(waiting) == "due"
    assert waiting.robot is None
    assert waiting.history.last().cause == "presence"
    assert enqueued == [waiting.pk]
    assert (status(loaded), loaded.robot) == ("picked_up", r1)
    alert = Alert.objects.get()
    assert (alert.kind, alert.robot, alert.task) == ("offline_with_load", r1, loaded.code)
    [corrected] = pending_plans(r1)  # what R1 gets when it comes back
    assert list(corrected.body["tasks"]) == [loaded.code]

    assert task_allocate(task_id=waiting.pk)
    waiting.refresh_from_db()
    assert waiting.robot == r2


def test_an_offline_robot_with_nothing_on_board_is_sent_to_its_dock(r1, site, enqueued):
    task = held_by(r1, site)
    Beater(r1).beat()

    presence_sweep(now=offline_time(r1))

    assert status(task) == "due"
    assert not Alert.objects.exists()
    [plan] = pending_plans(r1)
    assert plan.body["stops"][0]["action"] == "dock"


def test_an_unreachable_robot_keeps_its_tasks(r1, site):
    task = held_by(r1, site)
    Beater(r1).beat()
    r1.refresh_from_db()

    presence_sweep(now=r1.unreachable_at + timedelta(milliseconds=1))

    r1.refresh_from_db()
    assert r1.presence == "unreachable"
    assert status(task) == "assigned"
