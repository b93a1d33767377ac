"""Task moves held to the end of a unit of work (scheduling.services.history.task_moves_held):
written once, in order, or not at all."""

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from core import changes
from scheduling.choices import Cause, TaskStatus
from scheduling.models import Task
from scheduling.services.history import task_move, task_moves_held, task_moves_write
from tests.scheduling.conftest import request


def stored(task: Task) -> tuple[str, list[tuple[str, str]]]:
    """The task's status and history as the database has them."""
    fresh = Task.objects.get(pk=task.pk)
    return fresh.status, list(fresh.history.values_list("old", "new"))


def cancel_then_fail(task: Task) -> None:
    now = timezone.now()
    task.cancelled_at = now
    task_move(task, TaskStatus.CANCELLED, at=now, fields=["cancelled_at"], cause=Cause.USER)
    task.failed_at = now
    task_move(task, TaskStatus.FAILED, at=now, fields=["failed_at"], cause=Cause.USER)


def test_held_moves_are_written_and_told_in_order_at_the_end(site):
    task = request(site)
    told = []

    def page(*, kind, subject, **_):
        told.append((subject.old, subject.new, subject.pk is not None))

    with changes.changed.watched_by(page), task_moves_held():
        cancel_then_fail(task)
        assert stored(task) == ("due", [("", "due")])  # nothing yet
        assert told == []

    assert stored(task) == ("failed", [("", "due"), ("due", "cancelled"), ("cancelled", "failed")])
    assert told == [("due", "cancelled", True), ("cancelled", "failed", True)]
    fresh = Task.objects.get(pk=task.pk)
    assert (fresh.cancelled_at, fresh.failed_at) == (task.cancelled_at, task.failed_at)


def test_the_end_of_a_held_block_writes_a_task_and_its_history_in_one_statement_each(site):
    task = request(site)

    with CaptureQueriesContext(connection) as queries, task_moves_held():
        cancel_then_fail(task)

    sql = [q["sql"] for q in queries.captured_queries if not q["sql"].startswith("SELECT")]
    assert [s.split(" SET ")[0].split(" (")[0] for s in sql] == [
        'UPDATE "scheduling_task"',
        'INSERT INTO "scheduling_tasktransition"',
    ]


def test_an_exception_drops_what_is_held(site):
    task = request(site)

    def failing_unit_of_work():
        with task_moves_held():
            cancel_then_fail(task)
            raise RuntimeError("the unit of work failed")

    with pytest.raises(RuntimeError):
        failing_unit_of_work()

    assert stored(task) == ("due", [("", "due")])


def test_task_moves_write_writes_what_is_held_so_far_before_a_read(site):
    task = request(site)
    now = timezone.now()

    with task_moves_held():
        task_move(task, TaskStatus.CANCELLED, at=now, cause=Cause.USER)
        task_moves_write()
        assert stored(task) == ("cancelled", [("", "due"), ("due", "cancelled")])
        task_move(task, TaskStatus.FAILED, at=now, cause=Cause.USER)
        assert stored(task)[0] == "cancelled"  # held again

    assert stored(task)[0] == "failed"


def test_a_held_block_inside_another_is_the_outer_one(site):
    task = request(site)

    with task_moves_held():
        with task_moves_held():
            cancel_then_fail(task)
        assert stored(task)[0] == "due"

    assert stored(task)[0] == "failed"
