"""Stopping a periodic request: no more instances, and the upcoming ones are cancelled."""

from datetime import datetime

from django.db import transaction
from django.utils import timezone

from scheduling.choices import TaskStatus
from scheduling.models import RecurringRequest
from scheduling.services.cancellation import TaskNotCancellable, task_cancel


def recurring_stop(*, recurring: RecurringRequest, by, now: datetime | None = None) -> int | None:
    """Stop the series for user `by`; returns how many upcoming instances were cancelled, or
    None if it was already stopped. Instances already due or on their way are left to run
    (each can be cancelled on its own)."""
    now = now or timezone.now()
    with transaction.atomic():
        claimed = RecurringRequest.objects.filter(pk=recurring.pk, active=True).update(active=False)
    if not claimed:
        return None
    cancelled = 0
    for task in recurring.instances.filter(status=TaskStatus.SCHEDULED):
        try:
            task_cancel(task=task, by=by, now=now)
        except TaskNotCancellable:  # became due meanwhile and went to a robot: it runs
            continue
        cancelled += 1
    return cancelled
