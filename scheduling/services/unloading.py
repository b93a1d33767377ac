"""Robots waiting at a drop-off that nobody unloads: operators are alerted once per stop, past
the site's unload timeout (counted from the robot's `arrived`); past its longer unattended
timeout the robot moves on by the site's policy (Site.unattended_return): the items stay on
board, secure ones locked, and go back to the sender or to a return station; the task ends
failed when they are unloaded there, its custody record says so, operators are alerted and
the requester's row says why."""

from datetime import datetime, timedelta

from django.db import transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from boards.choices import EventType
from boards.models import RobotEvent
from core.said import Said
from robots.alerts import alert_raise, alerts_close
from robots.choices import RobotStatus
from robots.mapcache import waypoint_by_id
from robots.models import Alert, AlertKind, Robot, Waypoint
from robots.models.map import UNATTENDED_TO_PICKUP
from robots.selectors import REACHABLE
from robots.services import robot_lock
from scheduling.choices import Cause, StopAction, TaskStatus
from scheduling.models import CustodyEntry, CustodyKind, Task, TaskStop
from scheduling.services.cancellation import return_stop_add, task_origin
from scheduling.services.history import task_move, task_record
from scheduling.services.plans import robot_replan


def unload_timeout_sweep(*, now: datetime | None = None) -> int:
    """Alert about every drop-off waited at past the site's unload timeout; returns how many
    alerts were raised (each stop at most once, acknowledged or not)."""
    now = now or timezone.now()
    waiting = Robot.objects.filter(
        status=RobotStatus.WAITING_UNLOAD, presence__in=REACHABLE, waypoint__isnull=False
    ).select_related("site")
    return sum(_robot_overdue(robot, now) for robot in waiting)


def _robot_overdue(robot: Robot, now: datetime) -> int:
    return sum(_stop_overdue(robot, stop, now) for stop in _waited_at(robot))


def _waited_at(robot: Robot):
    """The drop-offs of the robot's loaded tasks where it stands."""
    stops = TaskStop.objects.remaining().filter(
        task__robot=robot,
        task__status=TaskStatus.PICKED_UP,
        action=StopAction.DROPOFF,
        waypoint_id=robot.waypoint_id,
    )
    return stops.select_related("task")


def _waited(robot: Robot, stop: TaskStop, now: datetime) -> timedelta | None:
    """How long the robot has waited at the stop since it reported `arrived` there."""
    arrivals = RobotEvent.objects.filter(robot=robot, type=EventType.ARRIVED, task=stop.task.code)
    arrived = arrivals.filter(stop=stop.index).order_by("-received_at").first()
    return None if arrived is None else now - arrived.received_at


def _stop_overdue(robot: Robot, stop: TaskStop, now: datetime) -> bool:
    task = stop.task
    waited = _waited(robot, stop, now)
    key = _alert_key(stop)
    if waited is None or waited < timedelta(seconds=robot.site.unload_timeout):
        return False
    if Alert.objects.filter(key=key).exists():  # once per stop, even once acknowledged
        return False
    station = waypoint_by_id(robot.site, stop.waypoint_id)
    place = station.label if station else "the drop-off"
    words = Said(
        gettext_noop(
            "%(robot)s has waited %(waited)s at %(place)s with %(contents)s %(code)s: nobody has "
            "unloaded it"
        ),
        robot=robot.code,
        waited=_duration(waited),
        place=place,
        contents=task.contents,
        code=task.code,
    )
    message = Said(
        gettext_noop("%(what)s. Call the station, or cancel it to bring the items back."),
        what=words,
    )
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.UNLOAD_TIMEOUT,
        key=key,
        message=message,
        robot=robot,
        task=task.code,
    )
    task_record(task, old=task.status, at=now, cause=Cause.UNLOADING, robot=robot, note=words)
    return True


def _alert_key(stop: TaskStop) -> str:
    return f"unload-timeout:{stop.task.code}:{stop.index}"


def _duration(waited: timedelta) -> str:
    """How long a robot waited, as a person would say it: "40 s", "5 min"."""
    seconds = round(waited.total_seconds())
    if seconds < 60:
        return f"{seconds} s"
    return f"{round(seconds / 60)} min"


def unattended_sweep(*, now: datetime | None = None) -> int:
    """Move every robot on from a drop-off waited at past its site's unattended timeout;
    returns how many tasks were sent back."""
    now = now or timezone.now()
    waiting = Robot.objects.filter(
        status=RobotStatus.WAITING_UNLOAD, presence__in=REACHABLE, waypoint__isnull=False
    ).select_related("site")
    moved = 0
    for robot in waiting:
        limit = timedelta(seconds=robot.site.unattended_timeout)
        for stop in _waited_at(robot):
            waited = _waited(robot, stop, now)
            if waited is not None and waited >= limit:
                moved += task_move_on(robot_id=robot.pk, stop_id=stop.pk, waited=waited, now=now)
    return moved


@transaction.atomic
def task_move_on(*, robot_id: int, stop_id: int, waited: timedelta, now: datetime) -> bool:
    """The robot leaves the drop-off with the items (secure ones still locked) for the site's
    return place; False if the stop was done, or the task moved, meanwhile. A task already
    going back (cancelled after pick-up, or moved on before) stays: where it waits is where
    it would be sent, and operators were alerted."""
    robot = robot_lock(robot_id)
    stop = (
        TaskStop.objects.remaining()
        .filter(pk=stop_id, task__robot=robot, task__status=TaskStatus.PICKED_UP)
        .filter(task__return_trip=False)
        .select_related("task")
        .first()
    )
    if stop is None:
        return False
    task, site = stop.task, robot.site
    stops = list(task.stops.select_related("waypoint"))
    back_to = _return_place(site, stops)
    return_stop_add(task=task, stops=stops, waypoint=back_to, now=now)
    entry = _custody_moved_on(task, robot, stop, now)
    where = _label(site, stop.waypoint_id, "the drop-off")
    locked = (
        Said(gettext_noop(", locked in compartment %(compartment)s"), compartment=entry.compartment)
        if entry.compartment
        else ""
    )
    words = Said(
        gettext_noop(
            "Nobody unloaded it at %(place)s in %(waited)s: %(robot)s moved on, taking it to "
            "%(back)s%(locked)s"
        ),
        place=where,
        waited=_duration(waited),
        robot=robot.code,
        back=back_to.label,
        locked=locked,
    )
    task.return_trip, task.unattended_at = True, now
    why = {"cause": Cause.UNLOADING, "robot": robot, "note": words}
    task_move(task, TaskStatus.PICKED_UP, at=now, fields=["return_trip", "unattended_at"], **why)
    alerts_close(key=_alert_key(stop), at=now)  # this alert says what became of it
    message = Said(
        gettext_noop(
            "%(what)s (%(code)s, %(contents)s). It is not delivered: call the receiver to order "
            "it again."
        ),
        what=words,
        code=task.code,
        contents=task.contents,
    )
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.UNATTENDED,
        key=f"unattended:{task.code}",
        message=message,
        robot=robot,
        task=task.code,
    )
    robot_replan(robot=robot, now=now)
    return True


def _return_place(site, stops: list[TaskStop]) -> Waypoint:
    """The site's policy: the task's first pick-up, or the return station it names (the
    pick-up if that station is gone from the map since)."""
    if site.unattended_return != UNATTENDED_TO_PICKUP:
        station = Waypoint.objects.filter(site=site, code=site.unattended_return).first()
        if station is not None:
            return station
    return task_origin(stops).waypoint


def _custody_moved_on(task: Task, robot: Robot, stop: TaskStop, now: datetime) -> CustodyEntry:
    """The custody record says the items left the drop-off undelivered, in which compartment."""
    loaded = task.custody.filter(kind=CustodyKind.LOADED).exclude(compartment="").last()
    return CustodyEntry.objects.create(
        task=task,
        kind=CustodyKind.MOVED_ON,
        at=now,
        robot=robot,
        station=_label(robot.site, stop.waypoint_id, ""),
        compartment=loaded.compartment if loaded else "",
    )


def _label(site, waypoint_id: int, default: str) -> str:
    waypoint = waypoint_by_id(site, waypoint_id)
    return waypoint.label if waypoint else default
