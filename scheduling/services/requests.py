"""Delivery requests: on-demand, scheduled, and periodic (which create instances on time)."""

import logging
from datetime import datetime, timedelta

from django.conf import settings
from django.db import IntegrityError, transaction
from django.db.models import Max
from django.utils import timezone
from django.utils.translation import gettext_noop

from audit.choices import Kind
from audit.services import entry_record
from core import memo
from core.said import Said
from robots.models import Site, Waypoint
from scheduling.choices import Cause, Priority, StopAction, TaskStatus
from scheduling.deadlines import due_at_default
from scheduling.models import RecurringRequest, Task, TaskStop
from scheduling.pins import pin_hash, pin_new, pin_seal
from scheduling.recurrence import next_occurrence, occurrences
from scheduling.selectors import stations_by_code
from scheduling.services.allocation import task_allocate_created
from scheduling.services.history import allocation_enqueue, task_record

logger = logging.getLogger(__name__)

# Instances of periodic requests are created this far ahead (the due sweep then makes them
# due on time), and occurrences missed while nothing ran are still created this far back.
RECURRING_LEAD = timedelta(minutes=10)
RECURRING_CATCH_UP = timedelta(minutes=10)
# Occurrences missed while the sweep did not run (Celery beat down) are created late, up to
# this far back (older ones are logged as skipped), and marked late in their history.
RECURRING_LATE_LIMIT = timedelta(hours=24)
RECURRING_LATE_AFTER = timedelta(minutes=1)


@transaction.atomic
def task_request(
    *,
    site: Site,
    requester,
    sender: str,
    receiver: str,
    contents: str,
    pickups: list[Waypoint],
    dropoffs: list[Waypoint],
    priority: str = Priority.ROUTINE,
    requested_time: datetime | None = None,
    due_by: datetime | None = None,
    repeat: dict | None = None,
    secure: bool = False,
    now: datetime | None = None,
) -> Task:
    """Create a delivery task (due at once unless requested for later), or with `repeat` a
    periodic request and its first instance, which is returned.

    It must be dropped off by `due_by`, else by the site's default for its priority. A `secure`
    one (never periodic: each has its own PIN) gets a new PIN, returned as task.pin_plain for
    the requester to hand to the recipient; it is stored hashed for robots and sealed for the
    pages that show it again (scheduling/pins.py).
    """
    now = now or timezone.now()
    what = {"sender": sender, "receiver": receiver, "contents": contents, "priority": priority}
    if repeat is None:
        pin = pin_new() if secure else ""
        task = task_create(
            site=site,
            requester=requester,
            what=what,
            pickups=pickups,
            dropoffs=dropoffs,
            requested_time=requested_time or now,
            due_by=due_by,
            now=now,
            **(_secure_fields(pin) if secure else {}),
        )
        task.pin_plain = pin
        return task
    if secure:
        raise ValueError("a secure delivery cannot repeat")
    starts_at = max(requested_time or now, now)
    recurring = _recurring_create(site, requester, what, pickups, dropoffs, repeat, starts_at)
    first = next_occurrence(repeat, starts_at)
    return _instance_create(recurring, first, pickups, dropoffs, now)


def _secure_fields(pin: str) -> dict:
    hashed = pin_hash(pin)
    return {
        "secure": True,
        "pin_salt": hashed.salt,
        "pin_iterations": hashed.iterations,
        "pin_hash": hashed.hash,
        "pin_digits": hashed.digits,
        "pin_sealed": pin_seal(pin),
    }


def _recurring_create(site, requester, what, pickups, dropoffs, repeat, starts_at):
    return RecurringRequest.objects.create(
        site=site,
        requester=requester,
        pickups=[wp.code for wp in pickups],
        dropoffs=[wp.code for wp in dropoffs],
        repeat=repeat,
        starts_at=starts_at,
        **what,
    )


@memo.scope()  # its history and its allocation both ask for the webhooks (core.memo)
def task_create(
    *,
    site: Site,
    requester,
    what: dict,
    pickups: list[Waypoint],
    dropoffs: list[Waypoint],
    requested_time: datetime,
    now: datetime,
    note: str = "",
    due_by: datetime | None = None,
    **extra,
) -> Task:
    """One task with its stops; allocated (settings.ALLOCATE_ON_REQUEST) or enqueued for
    allocation at once if its time has come."""
    due = requested_time <= now
    priority = what.get("priority", Priority.ROUTINE)
    task = Task(
        site=site,
        requester=requester,
        requested_time=requested_time,
        due_at=due_by
        or due_at_default(site=site, priority=priority, requested_time=requested_time),
        status=TaskStatus.DUE if due else TaskStatus.SCHEDULED,
        created_at=now,
        **what,
        **extra,
    )
    task.save(force_insert=True)
    stops = TaskStop.objects.bulk_create(task_stops_build(task, pickups, dropoffs))
    cause = Cause.SCHEDULE if extra.get("recurring") else Cause.REQUEST
    task_record(task, old="", at=now, cause=cause, user=requester, note=note)
    _order_audit(task, requester, cause)
    if due and settings.ALLOCATE_ON_REQUEST:
        task_allocate_created(task=task, stops=stops, now=now)
    elif due:
        allocation_enqueue(task)
    return task


def _order_audit(task: Task, requester, cause: str) -> None:
    """Who ordered the delivery: its requester (a nurse, a hospital system), or the recurring
    schedule acting for one."""
    by_schedule = cause == Cause.SCHEDULE
    entry_record(
        kind=Kind.TASK_ORDERED,
        obj=task,
        actor=None if by_schedule else requester,
        actor_name="recurring schedule" if by_schedule else "",
        data={
            "cause": cause,
            "requester": requester.get_username() if requester else "",
            "priority": task.priority,
            "secure": task.secure,
        },
    )


def task_stops_build(task: Task, pickups: list[Waypoint], dropoffs: list[Waypoint]):
    """One-to-one, one-to-many (pick-up +k, each drop-off -1) or many-to-one (each pick-up
    +1, drop-off -k); the pick-ups come first, so stop indexes put every drop-off after them."""
    if len(pickups) != 1 and len(dropoffs) != 1:
        raise ValueError("a task has exactly one pick-up or exactly one drop-off")
    one_pickup = len(pickups) == 1
    up = len(dropoffs) if one_pickup else 1
    down = -1 if one_pickup else -len(pickups)
    places = [(StopAction.PICKUP, wp, up) for wp in pickups]
    places += [(StopAction.DROPOFF, wp, down) for wp in dropoffs]
    return [
        TaskStop(task=task, index=n, action=action, waypoint=wp, load_change=change)
        for n, (action, wp, change) in enumerate(places)
    ]


def recurring_sweep(*, now: datetime | None = None) -> int:
    """Create the instances of periodic requests that fall due soon; returns how many."""
    now = now or timezone.now()
    active = RecurringRequest.objects.filter(active=True).select_related("site", "requester")
    return sum(recurring_instances_create(recurring=r, now=now) for r in active)


def recurring_instances_create(*, recurring: RecurringRequest, now: datetime) -> int:
    """Instances for the occurrences from a little before `now` to RECURRING_LEAD after it.

    Idempotent: one instance per occurrence (unique constraint), however often it runs.
    """
    start = _catch_up_from(recurring, now)
    wanted = list(occurrences(recurring.repeat, start, now + RECURRING_LEAD))
    existing = set(
        recurring.instances.filter(scheduled_for__in=wanted).values_list("scheduled_for", flat=True)
    )
    missing = [at for at in wanted if at not in existing]
    if not missing:
        return 0
    stations = stations_by_code(site=recurring.site, codes=recurring.pickups + recurring.dropoffs)
    try:
        pickups = [stations[code] for code in recurring.pickups]
        dropoffs = [stations[code] for code in recurring.dropoffs]
    except KeyError as gone:
        logger.error(
            "periodic request %s names station %s, no longer on the map", recurring.pk, gone
        )
        return 0
    return sum(_instance_created(recurring, at, pickups, dropoffs, now) for at in missing)


def _catch_up_from(recurring: RecurringRequest, now: datetime) -> datetime:
    """Where to look for missing occurrences: the last few minutes, or, when the newest
    instance is older than that (the sweep was not running), right after it."""
    newest = recurring.instances.aggregate(newest=Max("scheduled_for"))["newest"]
    start = now - RECURRING_CATCH_UP
    if newest is None or newest < start:
        start = newest + timedelta(microseconds=1) if newest else recurring.starts_at
    limit = now - RECURRING_LATE_LIMIT
    if start < limit:
        skipped = sum(1 for _ in occurrences(recurring.repeat, start, limit))
        if skipped:
            logger.warning(
                "periodic request %s: %d occurrences more than %s ago not created",
                recurring.pk,
                skipped,
                RECURRING_LATE_LIMIT,
            )
    return max(start, limit, recurring.starts_at)


def _instance_created(recurring, at, pickups, dropoffs, now) -> bool:
    try:
        with transaction.atomic():
            _instance_create(recurring, at, pickups, dropoffs, now)
    except IntegrityError:  # created concurrently by another sweep
        return False
    return True


def _instance_create(recurring, at, pickups, dropoffs, now) -> Task:
    what = {
        "sender": recurring.sender,
        "receiver": recurring.receiver,
        "contents": recurring.contents,
        "priority": recurring.priority,
    }
    late = now - at
    note = ""
    if late > RECURRING_LATE_AFTER:
        due = timezone.localtime(at).strftime("%H:%M")
        note = Said(
            gettext_noop("created late: due at %(due)s, %(minutes)s min ago"),
            due=due,
            minutes=late // timedelta(minutes=1),
        )
    return task_create(
        site=recurring.site,
        requester=recurring.requester,
        what=what,
        pickups=pickups,
        dropoffs=dropoffs,
        requested_time=at,
        now=now,
        note=note,
        recurring=recurring,
        scheduled_for=at,
    )
