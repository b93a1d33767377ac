"""Every change of a task goes through here: its status, its history entry, the live push."""

import logging
from datetime import datetime

from django.db import transaction

from core import changes
from core.outbox import send_soon
from scheduling.models import Task, TaskTransition
from scheduling.pending import allocation_pending_claim

logger = logging.getLogger(__name__)


def task_move(task: Task, new: str, *, at: datetime, fields=(), **why) -> None:
    """Set the task's status (and `fields` already set on it), save, record why.

    Call with the task's robot locked, or after claiming the row by a conditional update.
    """
    old, task.status = task.status, new
    task.save(update_fields=["status", *fields])
    task_record(task, old=old, at=at, **why)


def task_record(
    task: Task,
    *,
    old: str,
    at: datetime,
    cause: str,
    robot=None,
    event=None,
    user=None,
    note: str = "",
) -> TaskTransition:
    """Add an entry to the task's history (old == new for events that changed no status)."""
    entry = _entry(task, old, at, cause, robot=robot, event=event, user=user, note=note)
    entry.save(force_insert=True)
    changes.changed(kind=changes.TASK, site_id=task.site_id, subject=entry)
    return entry


def tasks_record(moved: list[tuple[Task, object]], *, old: str, at: datetime, cause: str) -> None:
    """task_record for several tasks (each with its robot) in one insert: an allocation batch
    gives a burst's tasks their robots together (bench/latency.py)."""
    entries = [_entry(task, old, at, cause, robot=robot) for task, robot in moved]
    for entry in TaskTransition.objects.bulk_create(entries):
        changes.changed(kind=changes.TASK, site_id=entry.task.site_id, subject=entry)


def _entry(task, old, at, cause, robot=None, event=None, user=None, note="") -> TaskTransition:
    return TaskTransition(
        task=task,
        at=at,
        old=old,
        new=task.status,
        cause=cause,
        robot=robot,
        event=event,
        user=user,
        note=note[:300],
    )


def allocation_enqueue(task: Task) -> None:
    """Ask a Celery worker to allocate the task, with every due task of its site, once this
    transaction commits; not if a message for the site is already on its way
    (scheduling/pending.py).

    Best effort: if the message is lost (or Redis is down) the due sweep allocates it.
    """
    task_id, site_id = task.pk, task.site_id
    send = lambda: _send_allocation(task_id, site_id)  # noqa: E731
    transaction.on_commit(lambda: send_soon(send, what=f"allocating task {task_id}"))


def _send_allocation(task_id: int, site_id: int) -> None:
    from scheduling.tasks import allocate_task  # the tasks module imports the services

    pending = allocation_pending_claim(site_id, allocate_task.app.conf.task_default_queue)
    if pending is not None:
        allocate_task.delay(task_id, pending=pending)
