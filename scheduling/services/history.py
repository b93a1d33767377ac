"""Every change of a task goes through here: its status, its history entry, the live push.

A unit of work that moves the same tasks several times can hold the writes to its end
(`task_moves_held`): a heartbeat reporting a delivery moves its task four times (acknowledged,
picked up, delivered, completed), eight statements one by one and two held.
"""

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from datetime import datetime

from django.db import transaction

from core import changes
from core.outbox import send_soon
from core.said import Said, in_english, words_of
from scheduling.models import Task, TaskTransition
from scheduling.pending import allocation_pending_claim

logger = logging.getLogger(__name__)


def task_move(task: Task, new: str, *, at: datetime, fields=(), **why) -> None:
    """Set the task's status (and `fields` already set on it), save, record why.

    Call with the task's robot locked, or after claiming the row by a conditional update.
    """
    old, task.status = task.status, new
    held = _HELD.get()
    if held is None:
        task.save(update_fields=["status", *fields])
    else:
        held.save(task, ["status", *fields])
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
    note: str | Said = "",
) -> TaskTransition:
    """Add an entry to the task's history (old == new for events that changed no status).
    While moves are held (task_moves_held) it is stored, and told, when they are written."""
    entry = _entry(task, old, at, cause, robot=robot, event=event, user=user, note=note)
    held = _HELD.get()
    if held is not None:
        held.entries.append(entry)
        return entry
    entry.save(force_insert=True)
    changes.changed(kind=changes.TASK, site_id=task.site_id, subject=entry)
    return entry


def tasks_record(moved: list[tuple[Task, object]], *, old: str, at: datetime, cause: str) -> None:
    """task_record for several tasks (each with its robot) in one insert: an allocation batch
    gives a burst's tasks their robots together (bench/latency.py)."""
    _entries_store([_entry(task, old, at, cause, robot=robot) for task, robot in moved])


def _entries_store(entries: list[TaskTransition]) -> None:
    """Insert history entries in one statement, then tell each (core.changes), in order."""
    for entry in TaskTransition.objects.bulk_create(entries):
        changes.changed(kind=changes.TASK, site_id=entry.task.site_id, subject=entry)


@dataclass
class _HeldMoves:
    tasks: dict[int, tuple[Task, set[str]]] = field(default_factory=dict)  # by id(task)
    entries: list[TaskTransition] = field(default_factory=list)

    def save(self, task: Task, fields: list[str]) -> None:
        self.tasks.setdefault(id(task), (task, set()))[1].update(fields)

    def write(self) -> None:
        """Each task once with every field its moves set, then the entries in one insert,
        told in the order they were recorded."""
        tasks, entries = list(self.tasks.values()), self.entries
        self.tasks, self.entries = {}, []
        for task, fields in tasks:
            task.save(update_fields=sorted(fields))
        _entries_store(entries)


_HELD: ContextVar[_HeldMoves | None] = ContextVar("task_moves_held", default=None)


@contextmanager
def task_moves_held() -> Iterator[None]:
    """Hold task_move's saves and task_record's entries until the block ends, then write
    them: each task moved saved once, its history entries in one insert, then told
    (core.changes) in order. Only around code that reads neither the tasks it moves nor
    their history from the database, or that calls task_moves_write() before it does; the
    tasks in memory are moved at once, as always. Held inside held is the outer block; an
    exception drops what is held, as the transaction it was in rolls back."""
    if _HELD.get() is not None:
        yield
        return
    held = _HeldMoves()
    token = _HELD.set(held)
    try:
        yield
        held.write()
    finally:
        _HELD.reset(token)


def task_moves_write() -> None:
    """Write what task_moves_held holds so far, before reading tasks or their history."""
    held = _HELD.get()
    if held is not None:
        held.write()


def _entry(task, old, at, cause, robot=None, event=None, user=None, note="") -> TaskTransition:
    """`note` in English, and as words for each reader's language when it is Said."""
    return TaskTransition(
        task=task,
        at=at,
        old=old,
        new=task.status,
        cause=cause,
        robot=robot,
        event=event,
        user=user,
        note=in_english(note)[:300],
        words=words_of(note),
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
