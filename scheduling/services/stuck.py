"""Stuck robots: a robot that says it is `moving` but gets nowhere (a blocked corridor, lost
localisation) for its site's stuck_timeout raises one alert, with where it is and what it
carries, and its deliveries' ETAs move later by the time it has lost.

Progress is recorded by each heartbeat (robots.models.Robot.apply_state sets progress_at); a
robot waiting in a lease queue (for a lift, a door, a corridor) is waiting its turn, not stuck.
The sweep claims each robot with a conditional UPDATE of stuck_since, so two sweeps, or a
heartbeat reporting progress meanwhile, never raise a second alert.
"""

from datetime import datetime, timedelta

from django.db import transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from core import changes
from core.said import Said
from resources.choices import LeaseState
from resources.models import Lease
from robots.alerts import alert_raise
from robots.choices import Presence, RobotStatus
from robots.mapcache import floor_code_by_id, waypoint_by_id
from robots.models import AlertKind, Robot
from scheduling.choices import ROUTE_STATUSES, Cause
from scheduling.models import Task
from scheduling.services.etas import etas_write
from scheduling.services.history import task_record


def stuck_sweep(*, now: datetime | None = None) -> int:
    """Alert about every robot moving without progress past its site's stuck_timeout, once per
    time it gets stuck; returns how many."""
    now = now or timezone.now()
    moving = Robot.objects.filter(
        status=RobotStatus.MOVING,
        presence=Presence.ONLINE,
        stuck_since__isnull=True,
        progress_at__isnull=False,
    ).select_related("site")
    queued = Lease.objects.live().filter(state=LeaseState.QUEUED).values_list("robot_id")
    due = [
        robot
        for robot in moving.exclude(pk__in=queued)
        if robot.progress_at <= now - timedelta(seconds=robot.site.stuck_timeout)
    ]
    return sum(robot_stuck(robot=robot, now=now) for robot in due)


@transaction.atomic
def robot_stuck(*, robot: Robot, now: datetime) -> bool:
    """Mark the robot stuck (if it still is as read), alert, and make its ETAs later."""
    claimed = Robot.objects.filter(
        pk=robot.pk,
        status=RobotStatus.MOVING,
        progress_at=robot.progress_at,
        stuck_since__isnull=True,
    ).update(stuck_since=now)
    if not claimed:
        return False  # it moved on, or another sweep got there first
    robot.stuck_since = now
    tasks = list(Task.objects.filter(robot=robot, status__in=ROUTE_STATUSES).order_by("pk"))
    lost = now - robot.progress_at
    where = _where(robot)
    alert_raise(
        site_id=robot.site_id,
        kind=AlertKind.ROBOT_STUCK,
        key=f"robot-stuck:{robot.code}",
        message=_message(robot, where, lost, tasks),
        robot=robot,
        task=tasks[0].code if tasks else "",
    )
    _later(robot, tasks, lost, where, now)
    return True


def _later(robot: Robot, tasks: list[Task], lost: timedelta, where: str, now: datetime) -> None:
    """Move each delivery's ETAs later by the time lost, and say why in its history."""
    for task in tasks:
        task.eta = task.eta and task.eta + lost
        task.pickup_eta = task.pickup_eta and task.pickup_eta + lost
    etas_write(tasks)
    if tasks:
        changes.changed(kind=changes.ETAS, site_id=robot.site_id, subject=tasks)
    note = Said(
        gettext_noop("%(robot)s is stuck at %(where)s: this delivery will be late"),
        robot=robot.code,
        where=where,
    )
    for task in tasks:
        task_record(task, old=task.status, at=now, cause=Cause.SWEEP, robot=robot, note=note)


def _where(robot: Robot) -> str:
    floor = floor_code_by_id(robot.site, robot.floor_id) or "an unknown floor"
    waypoint = waypoint_by_id(robot.site, robot.waypoint_id)
    place = f" near {waypoint.label}" if waypoint is not None else ""
    xy = (
        f" (x {robot.x:.1f}, y {robot.y:.1f})"
        if robot.x is not None and robot.y is not None
        else ""
    )
    return f"{floor}{place}{xy}"


def _message(robot: Robot, where: str, lost: timedelta, tasks: list[Task]) -> Said:
    carrying = (
        Said(gettext_noop("; its deliveries: %(codes)s"), codes=", ".join(t.code for t in tasks))
        if tasks
        else ""
    )
    return Said(
        gettext_noop(
            "%(robot)s reports moving but has not got anywhere for %(minutes)s min, at "
            "%(where)s, with %(load)s item(s) on board%(carrying)s."
        ),
        robot=robot.code,
        minutes=int(lost.total_seconds() // 60),
        where=where,
        load=robot.load,
        carrying=carrying,
    )
