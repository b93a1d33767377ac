"""Assignments a robot does not acknowledge in time are withdrawn and allocated again."""

from datetime import datetime

from django.db import transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from core.said import Said
from robots.services import robot_lock
from scheduling.choices import Cause, TaskStatus
from scheduling.models import Task
from scheduling.services.history import allocation_enqueue, task_record
from scheduling.services.plans import plan_withdraw_pending, robot_replan


def ack_timeout_sweep(*, now: datetime | None = None) -> int:
    """Withdraw every assignment whose acknowledgement deadline passed; returns how many."""
    now = now or timezone.now()
    overdue = Task.objects.filter(status=TaskStatus.ASSIGNED, ack_due_at__lte=now).values_list(
        "pk", "robot_id"
    )
    return sum(ack_timeout_step(task_id=pk, robot_id=robot_id, now=now) for pk, robot_id in overdue)


@transaction.atomic
def ack_timeout_step(*, task_id: int, robot_id: int, now: datetime) -> int:
    """Withdraw one overdue assignment, unless someone got there first (then 0).

    The robot is locked first, then the task claimed by a conditional update; its plan is
    withdrawn, a corrected plan without the task posted, and the task allocated again.
    """
    robot = robot_lock(robot_id)
    claimed = Task.objects.filter(
        pk=task_id, robot=robot, status=TaskStatus.ASSIGNED, ack_due_at__lte=now
    ).update(status=TaskStatus.DUE, robot=None, ack_due_at=None, eta=None, timed_out_robot=robot)
    if not claimed:
        return 0
    task = Task.objects.get(pk=task_id)
    note = Said(
        gettext_noop("%(robot)s did not acknowledge within %(seconds)s s"),
        robot=robot.code,
        seconds=f"{robot.site.ack_timeout:g}",
    )
    task_record(
        task, old=TaskStatus.ASSIGNED, at=now, cause=Cause.ACK_TIMEOUT, robot=robot, note=note
    )
    plan_withdraw_pending(robot=robot, reason=f"{task.code} not acknowledged in time", now=now)
    robot_replan(robot=robot, now=now)
    allocation_enqueue(task)
    return 1
