"""Cancellation in the three cases of protocol v1: withdrawn, replanned without it, returned."""

import pytest
from django.test import Client

from boards.models import BoardMessage
from scheduling.services import TaskNotCancellable, task_allocate, task_cancel
from tests.scheduling.conftest import Beater, event, pending_plans, plans, request, route, status


@pytest.fixture
def beater(r1):
    return Beater(r1)


def held(site, **fields):
    task = request(site, **fields)
    assert task_allocate(task_id=task.pk)
    return task


def test_a_waiting_task_is_simply_cancelled(site, staff):
    task = request(site)

    task_cancel(task=task, by=staff)

    assert status(task) == "cancelled"
    entry = task.history.last()
    assert (entry.old, entry.new, entry.cause, entry.user) == ("due", "cancelled", "user", staff)
    assert not BoardMessage.objects.exists()


def test_an_unacknowledged_task_is_withdrawn_from_the_board(r1, site, staff, beater):
    task = held(site)
    [plan] = pending_plans(r1)

    task_cancel(task=task, by=staff)

    assert status(task) == "cancelled"
    plan.refresh_from_db()
    assert plan.withdrawn_at is not None
    assert plan.withdraw_reason == f"{task.code} cancelled"
    [reply_plan] = plans(beater.beat())
    assert reply_plan["id"] != plan.public_id
    assert route(reply_plan) == [(None, None, "dock", "1F-DOCK-1")]


def test_an_acknowledged_task_leaves_a_new_plan(r1, site, staff, beater):
    kept = held(site)
    cancelled = held(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
    [acked] = plans(beater.beat())
    beater.beat(acks=[acked["id"]])
    assert status(cancelled) == "acknowledged"

    task_cancel(task=cancelled, by=staff)

    assert status(cancelled) == "cancelled"
    assert status(kept) == "acknowledged"
    [new] = plans(beater.beat())
    assert new["plan_version"] == acked["plan_version"] + 1
    assert list(new["tasks"]) == [kept.code]
    assert {stop["task"] for stop in new["stops"]} == {kept.code}
    assert BoardMessage.objects.get(pk=int(acked["id"][2:])).acked_at is not None


def test_a_picked_up_task_becomes_a_return_trip(r1, site, staff, beater):
    task = held(site, dropoffs=("3F-WARD",))
    beater.ack_all(beater.beat())
    beater.beat(waypoint="1F-PHARM", events=[event("loaded", task.code, 0)])
    assert status(task) == "picked_up"

    task_cancel(task=task, by=staff)

    task.refresh_from_db()
    assert (task.status, task.return_trip) == ("picked_up", True)
    stops = {stop.index: stop for stop in task.stops.all()}
    assert stops[1].skipped_at is not None
    assert (stops[2].action, stops[2].waypoint.code, stops[2].load_change) == (
        "dropoff",
        "1F-PHARM",
        -1,
    )
    [plan] = plans(beater.beat(waypoint="1F-HALL"))
    assert route(plan) == [(task.code, 2, "dropoff", "1F-PHARM")]

    reply = beater.ack_all(
        {"messages": [plan]}, waypoint="1F-PHARM", events=[event("unloaded", task.code, 2)]
    )
    assert status(task) == "cancelled"
    assert [route(p) for p in plans(reply)] == [[(None, None, "dock", "1F-DOCK-1")]]
    with pytest.raises(TaskNotCancellable):
        task_cancel(task=task, by=staff)


def test_a_partly_delivered_task_returns_what_is_left(r1, site, staff, beater):
    task = held(site, dropoffs=("2F-LAB", "3F-WARD"))
    beater.ack_all(beater.beat())
    beater.beat(waypoint="1F-PHARM", events=[event("loaded", task.code, 0)])
    beater.beat(floor="2F", waypoint="2F-LAB", events=[event("unloaded", task.code, 1)])

    task_cancel(task=task, by=staff)

    [plan] = plans(beater.beat(floor="2F", waypoint="2F-LAB"))
    assert route(plan) == [(task.code, 3, "dropoff", "1F-PHARM")]
    assert task.stops.get(index=3).load_change == -1
    assert plan["stops"][0]["via"] == ["2F-ELEV-WAIT", "1F-ELEV-WAIT"]


def test_a_delivered_or_finished_task_cannot_be_cancelled(r1, site, staff, beater):
    task = held(site)
    beater.beat(events=[event("loaded", task.code, 0), event("unloaded", task.code, 1)])
    assert status(task) == "delivered"

    with pytest.raises(TaskNotCancellable):
        task_cancel(task=task, by=staff)

    beater.beat(events=[event("task_completed", task.code)])
    response = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}").post(
        f"/api/v1/tasks/{task.code}/cancel"
    )
    assert response.status_code == 409
    assert response.json() == {"error": "conflict", "detail": f"{task.code} is completed"}


def test_cancelling_over_the_api_answers_the_task(r1, site, staff):
    task = held(site)

    response = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}").post(
        f"/api/v1/tasks/{task.code}/cancel"
    )

    assert response.status_code == 200
    body = response.json()
    assert (body["code"], body["status"], body["robot"]) == (task.code, "cancelled", "R1")
    assert body["history"][-1]["user"] == staff.username
