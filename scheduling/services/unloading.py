"""Robots waiting at a drop-off that nobody unloads: operators are alerted once per stop, past
the site's unload timeout (counted from the robot's `arrived`)."""

from datetime import datetime, timedelta

from django.utils import timezone

from boards.choices import EventType
from boards.models import RobotEvent
from robots.alerts import alert_raise
from robots.choices import RobotStatus
from robots.mapcache import waypoint_by_id
from robots.models import Alert, AlertKind, Robot
from robots.selectors import REACHABLE
from scheduling.choices import Cause, StopAction, TaskStatus
from scheduling.models import TaskStop
from scheduling.services.history import task_record


def unload_timeout_sweep(*, now: datetime | None = None) -> int:
    """Alert about every drop-off waited at past the site's unload timeout; returns how many
    alerts were raised (each stop at most once, acknowledged or not)."""
    now = now or timezone.now()
    waiting = Robot.objects.filter(
        status=RobotStatus.WAITING_UNLOAD, presence__in=REACHABLE, waypoint__isnull=False
    ).select_related("site")
    return sum(_robot_overdue(robot, now) for robot in waiting)


def _robot_overdue(robot: Robot, now: datetime) -> int:
    stops = TaskStop.objects.remaining().filter(
        task__robot=robot,
        task__status=TaskStatus.PICKED_UP,
        action=StopAction.DROPOFF,
        waypoint_id=robot.waypoint_id,
    )
    return sum(_stop_overdue(robot, stop, now) for stop in stops.select_related("task"))


def _stop_overdue(robot: Robot, stop: TaskStop, now: datetime) -> bool:
    task = stop.task
    arrivals = RobotEvent.objects.filter(robot=robot, type=EventType.ARRIVED, task=task.code)
    arrived = arrivals.filter(stop=stop.index).order_by("-received_at").first()
    limit = timedelta(seconds=robot.site.unload_timeout)
    key = f"unload-timeout:{task.code}:{stop.index}"
    if arrived is None or now - arrived.received_at < limit:
        return False
    if Alert.objects.filter(key=key).exists():  # once per stop, even once acknowledged
        return False
    station = waypoint_by_id(robot.site, stop.waypoint_id)
    minutes = max(1, round((now - arrived.received_at).total_seconds() / 60))
    words = (
        f"{robot.code} has waited {minutes} min at {station.label if station else 'the drop-off'} "
        f"with {task.contents} {task.code}: nobody has unloaded it"
    )
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.UNLOAD_TIMEOUT,
        key=key,
        message=f"{words}. Call the station, or cancel it to bring the items back.",
        robot=robot,
        task=task.code,
    )
    task_record(task, old=task.status, at=now, cause=Cause.SWEEP, robot=robot, note=words)
    return True
