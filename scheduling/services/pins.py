"""Re-sending a secure delivery's PIN to its recipient, through the channel the hospital has:
a notice on the receiving station's page, shown with the PIN to that unit's staff signed in
there (ui/selectors.py, `pin_readers`), until the items are handed over.

Nothing of the PIN leaves the database here: the history entry and the live event that
refreshes the station's pages say only that it was re-sent.
"""

from django.db import transaction
from django.utils import timezone

from scheduling.choices import Cause
from scheduling.models import Task
from scheduling.services.history import task_record

RESENT_NOTE = "PIN re-sent to the receiving station's staff"


class PinNotResendable(Exception):
    """Not this user's secure delivery, or its PIN is no longer handed on (delivered, ended)."""


def task_pin_resend(*, task: Task, user) -> Task:
    """Post the PIN of the user's own secure delivery again to its receiving station."""
    with transaction.atomic():
        task = Task.objects.select_for_update().get(pk=task.pk)
        if task.requester_id != user.pk:
            raise PinNotResendable("only the person who ordered it may re-send its PIN")
        if task.pin_to_hand_on() is None:
            raise PinNotResendable("its PIN is no longer needed: the delivery is not on its way")
        now = timezone.now()
        task.pin_resent_at = now
        task.save(update_fields=["pin_resent_at"])
        task_record(task, old=task.status, at=now, cause=Cause.USER, user=user, note=RESENT_NOTE)
    return task
