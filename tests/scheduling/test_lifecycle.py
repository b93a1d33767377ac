"""A task's life through real HTTP heartbeats (protocol v1): plan, ack, load, unload, done."""

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext

from boards.models import RobotEvent
from core import changes
from robots.models import Alert
from scheduling.models import Task, TaskTransition
from scheduling.services import task_allocate
from tests import factories
from tests.scheduling.conftest import Beater, event, pending_plans, plans, request, route, status
from ui.live.payloads import task_payload

AT_DOCK = {"floor": "1F", "waypoint": "1F-DOCK-1"}
AT_PHARMACY = {"floor": "1F", "waypoint": "1F-PHARM"}
AT_WARD = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}


def history(task: Task) -> list[tuple]:
    return list(task.history.values_list("old", "new", "cause"))


def test_it_runs_a_task_from_request_to_completion_over_http(robot_http, robot, site):
    robot_http.heartbeat(1, state=AT_DOCK)
    task = request(site, dropoffs=("3F-WARD",))
    assert task_allocate(task_id=task.pk)

    [plan] = plans(robot_http.heartbeat(2, state=AT_DOCK))
    assert plan["plan_version"] == 1
    assert plan["stops"] == [
        {"task": task.code, "stop": 0, "action": "pickup", "waypoint": "1F-PHARM"},
        {
            "task": task.code,
            "stop": 1,
            "action": "dropoff",
            "waypoint": "3F-WARD",
            "via": ["1F-ELEV-WAIT", "3F-ELEV-WAIT"],
        },
    ]
    assert plan["tasks"] == {
        task.code: {
            "contents": "Medication",
            "sender": "Pharmacy",
            "receiver": "Nurse Kim",
            "priority": "normal",
        }
    }
    assert status(task) == "assigned"

    assert plans(robot_http.heartbeat(3, state=AT_DOCK, acks=[plan["id"]])) == []
    assert status(task) == "acknowledged"

    robot_http.heartbeat(4, state=AT_PHARMACY, events=[event("loaded", task.code, 0)])
    assert status(task) == "picked_up"

    reply = robot_http.heartbeat(5, state=AT_WARD, events=[event("unloaded", task.code, 1)])
    assert status(task) == "delivered"
    [dock] = plans(reply)
    assert dock["plan_version"] == 2
    assert dock["tasks"] == {}
    assert dock["stops"] == [
        {"action": "dock", "waypoint": "1F-DOCK-1", "via": ["3F-ELEV-WAIT", "1F-ELEV-WAIT"]}
    ]

    reply = robot_http.heartbeat(6, state=AT_WARD, events=[event("task_completed", task.code)])
    assert status(task) == "completed"
    assert [p["id"] for p in plans(reply)] == [dock["id"]]  # still the dock plan, not a new one
    assert history(task) == [
        ("", "due", "request"),
        ("due", "assigned", "allocation"),
        ("assigned", "acknowledged", "robot_ack"),
        ("acknowledged", "picked_up", "robot_event"),
        ("picked_up", "delivered", "robot_event"),
        ("delivered", "completed", "robot_event"),
    ]
    task.refresh_from_db()
    assert None not in (task.acknowledged_at, task.picked_up_at, task.delivered_at, task.eta)


def test_a_duplicated_heartbeat_applies_its_events_once(robot_http, robot, site):
    robot_http.heartbeat(1, state=AT_DOCK)
    task = request(site)
    task_allocate(task_id=task.pk)
    loaded = event("loaded", task.code, 0)
    body = {"state": AT_PHARMACY, "events": [loaded]}

    robot_http.heartbeat(2, **body)
    robot_http.heartbeat(2, **body)
    robot_http.heartbeat(3, **body)

    assert status(task) == "picked_up"
    assert TaskTransition.objects.filter(task=task, event__isnull=False).count() == 2
    stop = task.stops.get(index=0)
    assert stop.done_by == RobotEvent.objects.get(event_id=loaded["id"])


def test_a_task_received_event_acknowledges_the_task(r1, site):
    task = request(site)
    task_allocate(task_id=task.pk)

    Beater(r1).beat(events=[event("task_received", task.code)])

    assert status(task) == "acknowledged"
    assert history(task)[-1] == ("assigned", "acknowledged", "robot_event")


@pytest.mark.parametrize(
    ("bad", "field", "message"),
    [
        ({"type": "loaded", "task": "T-9999", "stop": 0}, "events[1].task", "unknown task"),
        ({"type": "arrived", "task": "nonsense"}, "events[1].task", "unknown task"),
        ({"type": "task_completed"}, "events[1].task", "required"),
        ({"type": "loaded", "task": None, "stop": 7}, "events[1].stop", "has no stop 7"),
        ({"type": "loaded", "task": None}, "events[1].stop", "required"),
        ({"type": "loaded", "task": None, "stop": 1}, "events[1].stop", "drop-off"),
        ({"type": "unloaded", "task": None, "stop": 0}, "events[1].stop", "pick-up"),
    ],
)
def test_it_refuses_a_heartbeat_with_a_bad_task_event(r1, site, bad, field, message):
    task = request(site)
    task_allocate(task_id=task.pk)
    bad = {**bad, "task": bad.get("task") or task.code} if "task" in bad else bad
    events = [event("arrived"), event(**bad)]

    response = Beater(r1).post(events=events)

    assert response.status_code == 400
    assert response.json()["error"] == "invalid"
    assert message in response.json()["detail"][field][0], response.json()
    assert not RobotEvent.objects.exists()
    assert status(task) == "assigned"


def test_an_event_about_another_robots_task_is_recorded_as_an_anomaly_and_changes_nothing(
    r1, r2, site
):
    task = request(site)
    task_allocate(task_id=task.pk)
    task.refresh_from_db()
    other = Beater(r2 if task.robot == r1 else r1)

    other.beat(events=[event("loaded", task.code, 0)])

    assert status(task) == "assigned"
    old, new, cause = history(task)[-1]
    assert (old, new, cause) == ("assigned", "assigned", "anomaly")
    assert task.history.last().note == (
        f"{other.robot.code} reported loaded for a delivery that is another robot's: ignored"
    )


def test_a_failed_task_alerts_operators_and_leaves_the_plan(enqueued, r1, site):
    kept, failed = request(site), request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
    task_allocate(task_id=kept.pk)
    task_allocate(task_id=failed.pk)
    beater = Beater(r1)
    beater.ack_all(beater.beat())

    reply = beater.beat(events=[event("task_failed", failed.code, reason="lid open")])

    assert status(failed) == "due"  # nothing on board: another robot may do it (test_faults)
    alert = Alert.objects.get()
    assert (alert.kind, alert.task) == ("task_failed", failed.code)
    assert "lid open" in alert.message
    [plan] = plans(reply)
    assert {stop["task"] for stop in plan["stops"]} == {kept.code}
    assert list(plan["tasks"]) == [kept.code]


def test_a_robot_whose_last_task_fails_goes_to_its_dock(r1, site, enqueued):
    task = request(site)
    task_allocate(task_id=task.pk)

    reply = Beater(r1).beat(events=[event("task_failed", task.code)])

    assert [route(p) for p in plans(reply)] == [[(None, None, "dock", "1F-DOCK-1")]]
    assert len(pending_plans(r1)) == 1


def test_a_heartbeat_with_a_task_event_needs_eleven_more_queries(
    r1, site, django_assert_num_queries, fleet_counted_once
):
    task = request(site)
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.ack_all(beater.beat())

    # The heartbeat's own 7 (tests/boards/test_heartbeat_queries.py, with one event) + read the
    # task and its stops, mark the stop done, move the task, record it, find the site's webhook
    # subscriptions (none here; webhooks/services.py) (6) + the robot's progress
    # (scheduling.services.etas, 5): look for its arrival there (its dwell), read its route and
    # its plan, the live leases of the elevator and the door on its next leg (both free: no
    # wait to estimate), store the ETAs. A heartbeat without task events or plan acks needs
    # none more.
    with django_assert_num_queries(18):
        beater.beat(events=[event("loaded", task.code, 0)])
    with django_assert_num_queries(7):
        beater.beat(events=[event("arrived")])


def test_a_delivery_reported_at_once_writes_its_task_once_and_tells_every_step(r1, site):
    task = request(site)
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    [plan] = plans(beater.beat())
    told = []
    report = [
        event("loaded", task.code, 0),
        event("unloaded", task.code, 1),
        event("task_completed", task.code),
    ]

    def page(*, kind, subject, **_):
        if kind == changes.TASK:
            told.append(task_payload(subject)["status"])

    with changes.changed.watched_by(page), CaptureQueriesContext(connection) as queries:
        beater.beat(acks=[plan["id"]], events=report)

    # Four moves (acknowledged by the plan's ack, picked up, delivered, completed): the task
    # saved once with all they set, their history in one insert (task_moves_held).
    sql = [q["sql"] for q in queries.captured_queries]
    assert len([q for q in sql if q.startswith('UPDATE "scheduling_task" ')]) == 1
    assert len([q for q in sql if q.startswith('INSERT INTO "scheduling_tasktransition"')]) == 1
    assert history(task)[-4:] == [
        ("assigned", "acknowledged", "robot_ack"),
        ("acknowledged", "picked_up", "robot_event"),
        ("picked_up", "delivered", "robot_event"),
        ("delivered", "completed", "robot_event"),
    ]
    task.refresh_from_db()
    assert (task.status, task.ack_due_at) == ("completed", None)
    assert None not in (task.acknowledged_at, task.picked_up_at, task.delivered_at)
    assert task.completed_at == task.delivered_at
    assert told == ["acknowledged", "picked_up", "delivered", "completed"]  # the pages, in order


def test_a_busy_resource_on_the_next_leg_costs_three_queries_more(
    r1, r2, site, django_assert_num_queries, fleet_counted_once
):
    task = request(site)
    task_allocate(task_id=task.pk)
    holder, other = (r1, r2) if Task.objects.get(pk=task.pk).robot_id == r1.pk else (r2, r1)
    beater = Beater(holder)
    beater.ack_all(beater.beat())
    elevator = site.resources.get(code="ELEV")
    factories.lease_acquire(robot=other, resource=elevator, request_id="q-other", to_floor="3F")
    factories.lease_enter(robot=other, resource=elevator)

    # The 18 above + the busy elevator read, and its queue and typical hold for the wait
    # (resources.leases.resource_wait_estimate); the free door still costs nothing.
    with django_assert_num_queries(21):
        beater.beat(events=[event("loaded", task.code, 0)])
