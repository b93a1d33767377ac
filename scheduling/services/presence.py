"""A robot that goes offline gives back the tasks it has not picked up (protocol v1); so does
a robot an operator sends back to its dock (scheduling.services.operator)."""

from datetime import datetime

from django.utils.translation import gettext_noop

from core.said import Said, in_english
from robots.alerts import alert_raise
from robots.models import AlertKind, Robot
from scheduling.choices import ROUTE_STATUSES, Cause, TaskStatus
from scheduling.models import Task
from scheduling.services.history import allocation_enqueue, task_move, task_record
from scheduling.services.plans import plan_withdraw_pending, robot_replan


def robot_offline(*, robot: Robot, at: datetime) -> int:
    """Make the robot's tasks with nothing on board due again; returns how many.

    Called inside the presence change's transaction (robot row locked). Tasks with items on
    board stay with it (silence never drops a load); operators are alerted about those. The
    robot is posted a corrected plan, which it receives when it comes back.
    """
    went = Said(gettext_noop("%(robot)s went offline"), robot=robot.code)
    given_back, loaded = give_back_unloaded(robot, at, reason=went, cause=Cause.PRESENCE)
    if loaded:
        _alert_loaded(robot, loaded)
    note = Said(
        gettext_noop("%(robot)s went offline with the items on board: operators are alerted"),
        robot=robot.code,
    )
    for task in loaded:
        task_record(task, old=task.status, at=at, cause=Cause.PRESENCE, robot=robot, note=note)
    return len(given_back)


def robot_tasks_give_back(*, robot: Robot, at: datetime, by=None, note: str | Said = "") -> int:
    """Give the robot's tasks with nothing on board back to the scheduler, for an operator
    (`by`); returns how many. They become due and are allocated again (to other robots while
    this one is held). Tasks with items on board stay with it; it is posted a corrected plan.

    Call with the robot's row locked.
    """
    note = note or Said(
        gettext_noop("%(robot)s recalled to its dock by an operator"), robot=robot.code
    )
    given_back, _loaded = give_back_unloaded(
        robot, at, reason=note, cause=Cause.USER, user=by, note=note
    )
    return len(given_back)


def give_back_unloaded(robot: Robot, at: datetime, *, reason: str, **why):
    """Make the robot's tasks with nothing on board due again, each noted with `reason`
    unless `why` has a note, and post the robot a corrected plan; returns (given back, with
    items on board). Call with the robot's row locked."""
    why.setdefault("note", reason)
    tasks = list(
        Task.objects.filter(robot=robot, status__in=ROUTE_STATUSES).prefetch_related("stops")
    )
    loaded = [task for task in tasks if any(stop.done_at for stop in task.stops.all())]
    given_back = [task for task in tasks if task not in loaded]
    for task in given_back:
        task_give_back(task, robot, at, **why)
    if given_back:
        plan_withdraw_pending(robot=robot, reason=in_english(reason), now=at)
        robot_replan(robot=robot, now=at)
    return given_back, loaded


def task_give_back(task: Task, robot: Robot, at: datetime, *, avoid: bool = False, **why) -> None:
    """Take the task from the robot (nothing of it on board) and make it due again for the
    scheduler; with `avoid`, other robots go first. The caller posts the robot its corrected
    plan. Robot row locked."""
    task.robot, task.ack_due_at, task.eta = None, None, None
    fields = ["robot", "ack_due_at", "eta"]
    if avoid:
        task.timed_out_robot = robot
        fields.append("timed_out_robot")
    task_move(task, TaskStatus.DUE, at=at, fields=fields, robot=robot, **why)
    allocation_enqueue(task)


def _alert_loaded(robot: Robot, tasks: list[Task]) -> None:
    codes = ", ".join(task.code for task in tasks)
    alert_raise(
        site_id=robot.site_id,
        kind=AlertKind.OFFLINE_WITH_LOAD,
        key=f"offline-with-load:{robot.code}",
        message=Said(
            gettext_noop("%(robot)s went offline carrying %(codes)s"), robot=robot.code, codes=codes
        ),
        robot=robot,
        task=tasks[0].code,
    )
