"""Assignments not acknowledged in time are withdrawn and allocated again, exactly once."""

import threading
from datetime import timedelta

import pytest
from django.db import connection

from boards.models import BoardMessage
from scheduling.models import Task
from scheduling.services import ack_timeout_sweep, task_allocate
from tests.scheduling.conftest import Beater, pending_plans, request, route, status


def assigned(site, robot, **fields) -> Task:
    task = request(site, **fields)
    assert task_allocate(task_id=task.pk)
    task.refresh_from_db()
    assert task.robot == robot
    return task


def after_deadline(task: Task):
    return task.ack_due_at + timedelta(milliseconds=1)


def test_an_unacknowledged_assignment_is_withdrawn_and_reallocated_once(
    r1, r2, site, enqueued, django_capture_on_commit_callbacks
):
    task = assigned(site, r1)
    [plan] = pending_plans(r1)
    now = after_deadline(task)

    with django_capture_on_commit_callbacks(execute=True):
        assert ack_timeout_sweep(now=now) == 1
        assert ack_timeout_sweep(now=now) == 0

    task.refresh_from_db()
    assert (task.status, task.robot, task.timed_out_robot) == ("due", None, r1)
    assert enqueued == [task.pk]
    plan.refresh_from_db()
    assert plan.withdraw_reason == f"{task.code} not acknowledged in time"
    [corrected] = pending_plans(r1)
    assert route(corrected.body) == [(None, None, "dock", "1F-DOCK-1")]
    assert task.history.filter(cause="ack_timeout").count() == 1

    assert task_allocate(task_id=task.pk, now=now)  # what the enqueued message does
    task.refresh_from_db()
    assert task.robot == r2  # R1 let it time out, so R2 goes first


def test_it_waits_until_the_deadline(r1, site):
    task = assigned(site, r1)

    assert ack_timeout_sweep(now=task.ack_due_at - timedelta(milliseconds=1)) == 0
    assert status(task) == "assigned"


def test_an_acknowledged_assignment_never_times_out(r1, site):
    task = assigned(site, r1)
    beater = Beater(r1)
    beater.ack_all(beater.beat())

    assert ack_timeout_sweep(now=task.ack_due_at + timedelta(hours=1)) == 0
    assert status(task) == "acknowledged"


def test_the_only_robot_gets_the_task_again(r1, site):
    task = assigned(site, r1)
    ack_timeout_sweep(now=after_deadline(task))

    assert task_allocate(task_id=task.pk)

    task.refresh_from_db()
    assert (task.status, task.robot) == ("assigned", r1)
    [plan] = pending_plans(r1)
    assert plan.body["plan_version"] == 3  # the plan, the corrected plan, the plan again
    assert list(plan.body["tasks"]) == [task.code]


def test_the_corrected_plan_keeps_the_robots_acknowledged_tasks(r1, site):
    kept = assigned(site, r1)
    beater = Beater(r1)
    beater.ack_all(beater.beat())
    late = assigned(site, r1, pickups=("2F-LAB",), dropoffs=("3F-WARD",))

    assert ack_timeout_sweep(now=after_deadline(late)) == 1

    [plan] = pending_plans(r1)
    assert list(plan.body["tasks"]) == [kept.code]
    assert {stop["task"] for stop in plan.body["stops"]} == {kept.code}
    assert status(kept) == "acknowledged"


@pytest.mark.django_db(transaction=True)
def test_concurrent_sweeps_withdraw_an_assignment_exactly_once(r1, r2, site, enqueued):
    task = assigned(site, r1)
    now = after_deadline(task)
    barrier, counts = threading.Barrier(2), []
    enqueued.clear()  # the request's own allocation message

    def sweep():
        try:
            barrier.wait(timeout=10)
            counts.append(ack_timeout_sweep(now=now))
        finally:
            connection.close()

    threads = [threading.Thread(target=sweep) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30)

    assert sorted(counts) == [0, 1]
    assert enqueued == [task.pk]
    assert task.history.filter(cause="ack_timeout").count() == 1
    withdrawn = BoardMessage.objects.filter(robot=r1, withdraw_reason__contains="in time")
    assert withdrawn.count() == 1
    assert BoardMessage.objects.filter(robot=r1, type="plan").count() == 2
