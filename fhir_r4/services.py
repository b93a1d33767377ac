"""Writes of the FHIR endpoint: an order becomes a delivery (once, however often an interface
engine retries it), and an order is cancelled by the rules of a nurse's cancel."""

from collections import defaultdict

from django.db import IntegrityError, transaction

from audit.choices import Kind
from audit.services import entry_record
from core.access import can_cancel
from fhir_r4.models import Order
from fhir_r4.orders import OrderRequest
from fhir_r4.outcomes import FhirError
from fhir_r4.selectors import orders_matching
from scheduling.models import Task
from scheduling.services import TaskChanged, TaskNotCancellable, task_cancel, task_request


def order_create(*, user, order: OrderRequest) -> tuple[Task, bool]:
    """(the delivery, True) for a new order; (the delivery ordered before with the same
    identifier, False) for a retry, also one racing the first: the identifier is unique per
    site, and the later insert waits for the earlier's transaction, then finds it."""
    known = _ordered_before(user, order)
    if known is not None:
        return known, False
    try:
        return _create(user, order), True
    except IntegrityError:
        known = _ordered_before(user, order)
        if known is None:
            raise
        return known, False


def _ordered_before(user, order: OrderRequest) -> Task | None:
    if order.identifier is None:
        return None
    found = orders_matching(user, *order.identifier)
    return next((task for task in found if task.site_id == order.site.pk), None)


@transaction.atomic
def _create(user, order: OrderRequest) -> Task:
    task = task_request(
        site=order.site,
        requester=user,
        sender=order.sender,
        receiver=order.receiver,
        contents=order.contents,
        pickups=order.pickups,
        dropoffs=order.dropoffs,
        priority=order.priority,
        requested_time=order.requested_time,
        due_by=order.due_by,
        secure=order.secure,
    )
    system, value = order.identifier or ("", "")
    Order.objects.create(
        task=task,
        site=order.site,
        identifier_system=system,
        identifier_value=value,
        intent=order.intent,
        priority=order.fhir_priority,
        focus=order.focus,
        beneficiary=order.beneficiary,
        requester=order.requester,
    )
    return task


def order_cancel(*, user, task: Task, version: int | None, reason: str) -> None:
    """Cancel the delivery as a nurse would (core.access.can_cancel, task_cancel); with
    `version`, only if it is still the one the caller read (else FhirError 412)."""
    if not can_cancel(user, task):
        words = "only the system that ordered it, or an operator, may cancel it"
        raise FhirError.one(403, "forbidden", words, "Task.status")
    with transaction.atomic():
        try:
            task_cancel(task=task, by=user, history_count=version)
        except TaskChanged:
            words = "the Task has changed since that version: read it again"
            raise FhirError.one(412, "conflict", words, "http.If-Match") from None
        except TaskNotCancellable as refused:
            raise FhirError.one(422, "business-rule", str(refused), "Task.status") from None
        if reason:
            Order.objects.filter(task_id=task.pk).update(cancel_reason=reason[:200])


def orders_read_record(*, tasks, via: str) -> None:
    """Audit who read the patient-linked orders among `tasks` (those ordered over FHIR, which
    name a patient): one entry per site and read, naming each delivery."""
    by_site = defaultdict(list)
    for task in tasks:
        if getattr(task, "fhir_order", None) is not None:
            by_site[task.site_id].append(task)
    for site_id, read in by_site.items():
        _read_entry(site_id, read, via)


def order_read_record(*, task: Task, via: str) -> None:
    """Audit a read of one delivery's patient-linked order (the caller found it has one)."""
    _read_entry(task.site_id, [task], via)


def _read_entry(site_id: int, read: list[Task], via: str) -> None:
    codes = [task.code for task in read]
    entry_record(
        kind=Kind.ORDER_READ,
        obj=read[0] if len(read) == 1 else None,
        model=Task,
        site_id=site_id,
        object_repr=", ".join(codes)[:500],
        data={"via": via, "tasks": codes},
    )
