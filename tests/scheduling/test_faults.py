"""Robot faults and events that do not fit: operators alerted once, tasks moved at most once."""

from robots.models import Alert, Robot
from robots.selectors import robots_for_allocation
from scheduling.models import TaskTransition
from scheduling.services import robot_action, task_allocate
from tests import factories
from tests.scheduling.conftest import Beater, event, pending_plans, plans, request, status

AT_DOCK = {"floor": "1F", "waypoint": "1F-DOCK-1"}
AT_PHARMACY = {"floor": "1F", "waypoint": "1F-PHARM"}
FAULT = {**AT_PHARMACY, "status": "error", "errors": ["drive motor stalled"]}


def held_by(robot, site, **fields):
    """A task allocated to `robot`: the site's other robots are held meanwhile."""
    others = Robot.objects.filter(site=site, paused_by_operator=False).exclude(pk=robot.pk)
    held = list(others.values_list("pk", flat=True))
    others.update(paused_by_operator=True)
    task = request(site, **fields)
    assert task_allocate(task_id=task.pk)
    Robot.objects.filter(pk__in=held).update(paused_by_operator=False)
    task.refresh_from_db()
    assert task.robot == robot
    return task


def given_back(task) -> list[TaskTransition]:
    return list(task.history.filter(new="due", cause="robot_fault"))


def test_a_robot_in_error_gives_back_what_it_has_not_loaded_once_over_http(
    robot_http, robot, r2, site, enqueued
):
    robot_http.heartbeat(1, state=AT_DOCK)
    loaded = held_by(robot, site)
    waiting = held_by(robot, site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
    [plan] = plans(robot_http.heartbeat(2, state=AT_DOCK))
    robot_http.heartbeat(3, state=AT_PHARMACY, acks=[plan["id"]])
    robot_http.heartbeat(4, state=AT_PHARMACY, events=[event("loaded", loaded.code, 0)])
    assert (status(loaded), status(waiting)) == ("picked_up", "acknowledged")
    enqueued.clear()  # their requests'

    reply = robot_http.heartbeat(5, state=FAULT)
    robot_http.heartbeat(6, state=FAULT)  # it keeps saying so: nothing more happens
    assert robot_http.post(factories.heartbeat_body(6, state=FAULT)).status_code == 200  # again

    assert status(waiting) == "due"
    assert len(given_back(waiting)) == 1
    assert enqueued == [waiting.pk]
    assert (status(loaded), loaded.robot) == ("picked_up", robot)
    [alert] = Alert.objects.all()
    assert (alert.kind, alert.robot, alert.task) == ("robot_error", robot, loaded.code)
    assert "drive motor stalled" in alert.message
    assert f"Still on board: {loaded.code}" in alert.message
    assert f"Given to other robots: {waiting.code}" in alert.message
    [corrected] = plans(reply)  # only what is on board is left on its route
    assert list(corrected["tasks"]) == [loaded.code]

    assert task_allocate(task_id=waiting.pk)
    waiting.refresh_from_db()
    assert waiting.robot == r2
    robot_http.heartbeat(7, state={**AT_PHARMACY, "status": "idle"})  # back to normal by itself
    assert robot not in robots_for_allocation(site=site)  # held until an operator resolves it
    assert len(given_back(waiting)) == 1
    assert status(waiting) == "assigned"
    assert Alert.objects.count() == 1


def test_an_out_of_order_task_completed_does_not_complete_the_task_over_http(
    robot_http, robot, site
):
    robot_http.heartbeat(1, state=AT_DOCK)
    task = held_by(robot, site)
    robot_http.heartbeat(2, state=AT_DOCK)

    robot_http.heartbeat(3, state=AT_DOCK, events=[event("task_completed", task.code)])
    robot_http.heartbeat(4, state=AT_PHARMACY, events=[event("unloaded", task.code, 1)])

    assert status(task) == "assigned"
    task.refresh_from_db()
    assert (task.completed_at, task.delivered_at, task.acknowledged_at) == (None, None, None)
    anomalies = list(task.history.filter(cause="anomaly").values_list("old", "new", "note"))
    assert anomalies == [
        ("assigned", "assigned", "R1 reported it completed before it was picked up: ignored"),
        ("assigned", "assigned", "R1 reported unloaded before everything was loaded: ignored"),
    ]
    [alert] = Alert.objects.all()  # one per task while open
    assert (alert.kind, alert.task) == ("event_anomaly", task.code)

    robot_http.heartbeat(5, state=AT_PHARMACY, events=[event("loaded", task.code, 0)])
    robot_http.heartbeat(6, state=AT_PHARMACY, events=[event("unloaded", task.code, 1)])
    robot_http.heartbeat(7, state=AT_PHARMACY, events=[event("task_completed", task.code)])
    assert status(task) == "completed"


def test_completed_before_the_last_drop_off_leaves_a_picked_up_task(r1, site):
    task = held_by(r1, site)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0), event("task_completed", task.code)])

    assert status(task) == "picked_up"
    assert task.history.last().note == (
        "R1 reported it completed before its last drop-off: ignored"
    )


def test_loaded_for_another_robots_task_is_an_anomaly(r1, r2, site):
    task = held_by(r1, site)

    Beater(r2).beat(events=[event("loaded", task.code, 0)])

    assert status(task) == "assigned"
    assert not task.stops.filter(done_at__isnull=False).exists()
    [alert] = Alert.objects.all()
    assert (alert.kind, alert.robot, alert.task) == ("event_anomaly", r2, task.code)


def test_resume_resolves_the_fault_and_closes_its_alert(r1, site, operator, enqueued):
    task = held_by(r1, site)
    beater = Beater(r1)
    beater.beat(status="error", errors=["bumper pressed"])
    assert status(task) == "due"
    assert r1 not in robots_for_allocation(site=site)

    robot_action(robot=r1, action="resume", by=operator)

    r1.refresh_from_db()
    assert r1.fault_at is None
    alert = Alert.objects.get()
    assert (alert.acknowledged_by, alert.acknowledged_at is not None) == (operator, True)
    beater.beat()  # fixed
    assert r1 in robots_for_allocation(site=site)


def test_an_errors_list_alone_is_a_fault(r1, site, enqueued):
    task = held_by(r1, site)

    Beater(r1).beat(status="moving", errors=["lid sensor"])

    assert status(task) == "due"
    assert Alert.objects.get().kind == "robot_error"
    [plan] = pending_plans(r1)
    assert plan.body["stops"][0]["action"] == "dock"


def test_a_task_failed_before_pick_up_goes_to_another_robot_once(r1, r2, site):
    task = held_by(r1, site)

    Beater(r1).beat(events=[event("task_failed", task.code, reason="cannot reach")])

    assert status(task) == "due"
    task.refresh_from_db()
    assert task.timed_out_robot == r1
    assert task_allocate(task_id=task.pk)
    task.refresh_from_db()
    assert task.robot == r2  # the robot that failed it goes last
    assert "given to another robot" in Alert.objects.get().message

    Beater(r2).beat(events=[event("task_failed", task.code, reason="cannot reach either")])

    assert status(task) == "failed"
    assert Alert.objects.count() == 1  # the same delivery's alert, still open
