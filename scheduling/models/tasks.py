"""Delivery tasks, their stops and their history."""

from django.conf import settings
from django.db import models
from django.db.models import Q
from django.utils import timezone

from core.codes import code_pk
from core.said import said_text
from scheduling.choices import (
    FINISHED_STATUSES,
    ROUTE_STATUSES,
    WAITING_STATUSES,
    Cause,
    Priority,
    StopAction,
    TaskStatus,
)
from scheduling.pins import PinHash, pin_unseal

CODE_PREFIX = "T-"
# A secure delivery's PIN is shown to those who hand it on until its items are handed over.
PIN_SHOWN_STATUSES = frozenset([*WAITING_STATUSES, *ROUTE_STATUSES])


def task_code(pk: int) -> str:
    """T-0042: a task's public code, derived from its primary key."""
    return f"{CODE_PREFIX}{pk:04d}"


def task_pk(code: str) -> int | None:
    """The primary key of a task code, or None if `code` is not one (T-42 is not T-0042)."""
    pk = code_pk(code, CODE_PREFIX)
    return pk if pk is not None and task_code(pk) == code else None


class TaskQuerySet(models.QuerySet):
    def with_code(self, code: str):
        pk = task_pk(code)
        return self.none() if pk is None else self.filter(pk=pk)

    def with_codes(self, codes):
        return self.filter(pk__in=[pk for pk in map(task_pk, codes) if pk is not None])


class Task(models.Model):
    """One delivery: items picked up at one or more stations and dropped off at others."""

    site = models.ForeignKey("robots.Site", on_delete=models.PROTECT, related_name="tasks")
    requester = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL
    )
    sender = models.CharField(max_length=200)
    receiver = models.CharField(max_length=200)
    contents = models.CharField(max_length=200)
    priority = models.CharField(max_length=8, choices=Priority, default=Priority.ROUTINE)
    requested_time = models.DateTimeField(help_text="when a robot should come for it")
    status = models.CharField(max_length=16, choices=TaskStatus, default=TaskStatus.SCHEDULED)
    robot = models.ForeignKey(
        "robots.Robot", null=True, blank=True, on_delete=models.SET_NULL, related_name="tasks"
    )
    timed_out_robot = models.ForeignKey(
        "robots.Robot",
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="+",
        help_text="the last robot that did not acknowledge it in time; others go first",
    )
    recurring = models.ForeignKey(
        "scheduling.RecurringRequest",
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="instances",
    )
    scheduled_for = models.DateTimeField(
        null=True, blank=True, help_text="the occurrence of its periodic request"
    )
    return_trip = models.BooleanField(
        default=False, help_text="cancelled after pick-up: going back to its pick-up point"
    )
    unattended_at = models.DateTimeField(
        null=True,
        blank=True,
        help_text="when its robot moved on from a drop-off nobody unloaded (a return trip too)",
    )
    # A secure delivery (controlled medication, specimens) travels locked in a compartment
    # that opens for the recipient's PIN (scheduling/pins.py: robots get its salted slow hash;
    # people who must hand it on see it unsealed) and goes only to robots with a lockable
    # compartment.
    secure = models.BooleanField(default=False)
    pin_salt = models.CharField(max_length=64, blank=True, editable=False)
    pin_iterations = models.PositiveIntegerField(default=0, editable=False)
    pin_hash = models.CharField(max_length=128, blank=True, editable=False)
    pin_digits = models.PositiveSmallIntegerField(default=0, editable=False)
    pin_sealed = models.TextField(blank=True, editable=False)
    # When its requester last re-sent the PIN to the receiving station (a notice on its page
    # for the unit's staff; scheduling/services/pins.py).
    pin_resent_at = models.DateTimeField(null=True, blank=True, editable=False)
    waiting_reason = models.CharField(
        max_length=200, blank=True, help_text="why no robot took it yet"
    )
    created_at = models.DateTimeField(default=timezone.now)
    assigned_at = models.DateTimeField(null=True, blank=True)
    ack_due_at = models.DateTimeField(null=True, blank=True)
    acknowledged_at = models.DateTimeField(null=True, blank=True)
    picked_up_at = models.DateTimeField(null=True, blank=True)
    delivered_at = models.DateTimeField(null=True, blank=True)
    completed_at = models.DateTimeField(null=True, blank=True)
    cancelled_at = models.DateTimeField(null=True, blank=True)
    failed_at = models.DateTimeField(null=True, blank=True)
    eta = models.DateTimeField(null=True, blank=True, help_text="estimated last drop-off")
    pickup_eta = models.DateTimeField(null=True, blank=True, help_text="estimated first pick-up")
    due_at = models.DateTimeField(
        null=True, blank=True, help_text="when it must be dropped off (by its priority)"
    )

    objects = TaskQuerySet.as_manager()

    class Meta:
        ordering = ["-id"]
        constraints = [
            models.UniqueConstraint(
                fields=["recurring", "scheduled_for"],
                condition=Q(recurring__isnull=False),
                name="task_one_per_occurrence",
            ),
        ]
        indexes = [
            models.Index(fields=["status", "requested_time"], name="task_status_time"),
            models.Index(
                fields=["ack_due_at"],
                condition=Q(status=TaskStatus.ASSIGNED),
                name="task_ack_due",
            ),
            models.Index(fields=["robot", "status"], name="task_robot_status"),
            # The reports (reports/selectors.py): a site's tasks requested within a period.
            models.Index(fields=["site", "requested_time"], name="task_site_requested"),
        ]

    def __str__(self):
        return self.code

    @property
    def code(self) -> str:
        return task_code(self.pk)

    def pin_to_hand_on(self) -> str | None:
        """The PIN in clear while the delivery is on its way (to show to its requester and to
        the receiving station's staff), else None."""
        if not (self.secure and self.pin_sealed) or self.status not in PIN_SHOWN_STATUSES:
            return None
        return pin_unseal(self.pin_sealed)

    @property
    def pin(self):
        """The PIN's hash (scheduling.pins.PinHash) of a secure delivery, else None."""
        if not self.secure or not self.pin_hash:
            return None
        return PinHash(
            salt=self.pin_salt,
            iterations=self.pin_iterations,
            hash=self.pin_hash,
            digits=self.pin_digits,
        )

    @property
    def is_cancellable(self) -> bool:
        """Whether a user may still cancel it (scheduling.services.task_cancel decides for sure):
        not delivered, not finished, not already on its way back."""
        finished = self.status in FINISHED_STATUSES or self.status == TaskStatus.DELIVERED
        return not finished and not self.return_trip


class TaskStopQuerySet(models.QuerySet):
    def remaining(self):
        return self.filter(done_at__isnull=True, skipped_at__isnull=True)


class TaskStop(models.Model):
    """A pick-up or drop-off; `index` is the protocol's `stop`. Drop-offs follow all pick-ups."""

    task = models.ForeignKey(Task, on_delete=models.CASCADE, related_name="stops")
    index = models.PositiveSmallIntegerField()
    action = models.CharField(max_length=8, choices=StopAction)
    waypoint = models.ForeignKey("robots.Waypoint", on_delete=models.PROTECT, related_name="+")
    load_change = models.SmallIntegerField(help_text="items on board after minus before")
    done_at = models.DateTimeField(null=True, blank=True)
    done_by = models.ForeignKey(
        "boards.RobotEvent", null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    skipped_at = models.DateTimeField(
        null=True, blank=True, help_text="dropped from the task (a return trip replaced it)"
    )

    objects = TaskStopQuerySet.as_manager()

    class Meta:
        ordering = ["task", "index"]
        constraints = [
            models.UniqueConstraint(fields=["task", "index"], name="task_stop_index_unique"),
        ]

    def __str__(self):
        return f"{task_code(self.task_id)} stop {self.index} {self.action}"

    @property
    def is_remaining(self) -> bool:
        return self.done_at is None and self.skipped_at is None


class TaskTransition(models.Model):
    """One entry of a task's history: a status change, or an event that changed none."""

    task = models.ForeignKey(Task, on_delete=models.CASCADE, related_name="history")
    at = models.DateTimeField()
    old = models.CharField(max_length=16, choices=TaskStatus, blank=True)
    new = models.CharField(max_length=16, choices=TaskStatus)
    cause = models.CharField(max_length=16, choices=Cause)
    robot = models.ForeignKey(
        "robots.Robot", null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    event = models.ForeignKey(
        "boards.RobotEvent", null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    user = models.ForeignKey(
        settings.AUTH_USER_MODEL,
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="+",
    )
    note = models.CharField(max_length=300, blank=True)
    words = models.JSONField(
        null=True, blank=True, help_text="the note to show in each reader's language (core/said)"
    )

    class Meta:
        ordering = ["id"]
        indexes = [
            # The reports' failures and cancellations within a period.
            models.Index(
                fields=["at"],
                condition=Q(new__in=[TaskStatus.FAILED, TaskStatus.CANCELLED]),
                name="task_transition_ended",
            ),
        ]

    def __str__(self):
        return f"{task_code(self.task_id)}: {self.old or '-'} -> {self.new} ({self.cause})"

    @property
    def text(self) -> str:
        """The note in the reader's language."""
        return said_text(self.words, self.note)
