"""A fire alarm: started and ended in one action, by an operator or by the building.

While it is in force at a site:

* every robot on the floors it covers that can reach a refuge point (a waypoint of kind
  `refuge`) on its floor without a lift is sent to the nearest one by a plan: a `dock` stop
  there, then its task stops (plans.plan_refuge_post), so it keeps its tasks and waits there;
  VDA 5050 vehicles get the order the bridge makes of it, which ends at the refuge. Any other
  robot there is told to pause (protocol v1 `action`), so it stops where it is; VDA 5050
  vehicles get `startPause`. A robot an operator had already paused stays as the operator
  left it. A robot inside a lift, a door or a corridor (`in_resource`), or standing in the
  lobby or doorway where robots wait for one, is not stopped there, where it would block the
  car or a fire door: it is dealt with by its first heartbeat outside
  (emergency_heartbeat_check), like a robot that reaches a covered floor, or comes back
  online, while the alarm lasts;
* no elevator of the site is granted (resources.leases._free reads Site.fire_alarm_since):
  the fire service recalls the cars. A grant not yet used is taken back (the robot is queued
  again, first in line); a car with a robot inside stops at its next floor and the robot is
  told to get out there (`elevator_exit`, through scheduling.hooks.fire_alarm_changed: the
  building drives the cars). It keeps its lease until it reports itself out, and is then
  dealt with as any robot out of a lift (emergency_heartbeat_check);
* nothing is planned (the allocator holds every due task with a reason the pages show); new
  deliveries are still accepted and wait, in their order;
* every page of the site shows it, as an alert no operator can acknowledge away.

The all-clear resumes the robots the alarm paused (not those an operator paused meanwhile),
sends a car still carrying a robot on to that robot's destination,
posts the robots it sent to refuges their plans without the refuge, grants the elevators'
queues in order, and allocates the held deliveries in their order, with new ETAs. Nothing is
cancelled or failed by the alarm, so nothing is lost or done twice.

Lock order, as everywhere in the scheduler: the site's allocation lock first (so no allocation
is half-way when the flag changes), then robot rows one by one, then the Emergency row (a
heartbeat holds its robot's row when it adds the robot to the stopped ones), then resource rows.
"""

from dataclasses import dataclass
from datetime import datetime

from django.db import IntegrityError, transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from audit.choices import Kind
from audit.services import entry_record
from boards import protocol
from boards.choices import MessageType
from boards.services import board_post
from core.said import Said
from resources.leases import lease_grants_take_back, resource_lock, resource_serve
from robots.alerts import alert_raise, alerts_close
from robots.choices import (
    EmergencyKind,
    EmergencySource,
    ResourceKind,
    RobotStatus,
    WaypointKind,
)
from robots.mapcache import floor_code_by_id, router_for, site_map
from robots.models import AlertKind, Emergency, Resource, Robot, Site
from robots.selectors import emergency_active, robot_position
from robots.services import robot_lock, robot_publish
from scheduling.choices import ROUTE_STATUSES, Cause, OperatorActionKind
from scheduling.hooks import fire_alarm_changed
from scheduling.models import Task
from scheduling.services.allocation import allocation_lock_take, site_allocate_due
from scheduling.services.history import task_record
from scheduling.services.operator import ACTION_KEY
from scheduling.services.plans import plan_refuge_post, robot_replan

REASON_MAX = 200
HELD_NOTE = "Held: fire alarm. The robot waits where it is until the all-clear."
REFUGE_NOTE = "Held: fire alarm. The robot waits at refuge point {refuge} until the all-clear."
RESUMED_NOTE = "Fire alarm over: on its way again."


class EmergencyRefused(Exception):
    """The request cannot be carried out; `field` names what is wrong (None: the state)."""

    def __init__(self, message: str, *, field: str | None = None):
        super().__init__(message)
        self.field = field


@dataclass(frozen=True)
class EmergencyEnded:
    emergency: Emergency
    resumed: list[str]  # robots told to resume
    allocated: int  # held deliveries given a robot at once


@transaction.atomic
def emergency_start(
    *,
    site: Site,
    floors: list[str],
    reason: str,
    via: str,
    by=None,
    now: datetime | None = None,
) -> Emergency:
    """Start a fire alarm on `floors` of the site (empty: every floor); EmergencyRefused if a
    floor is not the site's or one is already in force."""
    now = now or timezone.now()
    floors = _floors_checked(site, floors)
    site = allocation_lock_take(site.pk)
    claimed = Site.objects.filter(pk=site.pk, fire_alarm_since__isnull=True)
    if not claimed.update(fire_alarm_since=now):
        raise EmergencyRefused(f"A fire alarm is already in force at {site}.")
    site.fire_alarm_since = now
    try:
        with transaction.atomic():
            emergency = Emergency.objects.create(
                site=site,
                kind=EmergencyKind.FIRE_ALARM,
                floors=floors,
                reason=reason[:REASON_MAX],
                started_at=now,
                started_by=by,
                started_via=via,
            )
    except IntegrityError:  # an open row without the flag: the same alarm, started meanwhile
        raise EmergencyRefused(f"A fire alarm is already in force at {site}.") from None
    for robot in _robots_to_stop(site, emergency):
        _stop(emergency, robot_lock(robot.pk), by, now)
    emergency.save(update_fields=["stopped_robots", "refuges"])
    for resource in Resource.objects.filter(site=site, kind=ResourceKind.ELEVATOR).order_by("pk"):
        lease_grants_take_back(resource=resource_lock(resource.pk))
    fire_alarm_changed(site=site, active=True, reason=_exit_reason(emergency), now=now)
    _audit(emergency, "fire_alarm", by=by, via=via)
    alert_raise(
        site_id=site.pk,
        kind=AlertKind.FIRE_ALARM,
        key=_alert_key(site),
        message=_alert_message(emergency, by),
    )
    return emergency


@transaction.atomic
def emergency_end(*, site: Site, via: str, by=None, now: datetime | None = None) -> EmergencyEnded:
    """The all-clear: resume the robots the alarm stopped, grant the elevators' queues,
    allocate the held deliveries; EmergencyRefused if no alarm is in force."""
    now = now or timezone.now()
    site = allocation_lock_take(site.pk)
    if emergency_active(site=site) is None:
        raise EmergencyRefused(f"No fire alarm is in force at {site}.")
    # The flag first: a heartbeat that waited for its robot's row stops no robot after this.
    Site.objects.filter(pk=site.pk).update(fire_alarm_since=None)
    for robot_id in Robot.objects.filter(site=site).order_by("pk").values_list("pk", flat=True):
        robot_lock(robot_id)
    emergency = Emergency.objects.select_for_update().get(pk=emergency_active(site=site).pk)
    emergency.ended_at, emergency.ended_by, emergency.ended_via = now, by, via
    emergency.save(update_fields=["ended_at", "ended_by", "ended_via"])
    resumed = [code for code in emergency.stopped_robots if _resume(site, code, by, now)]
    for code in emergency.refuges:
        _from_refuge(site, code, by, now)
    _audit(emergency, "all_clear", by=by, via=via)
    alerts_close(key=_alert_key(site), by=by, at=now)
    allocated = site_allocate_due(site_id=site.pk, now=now)
    fire_alarm_changed(site=site, active=False, reason="", now=now)
    for resource in Resource.objects.filter(site=site, kind=ResourceKind.ELEVATOR).order_by("pk"):
        resource_serve(resource=resource_lock(resource.pk), now=now)
    return EmergencyEnded(emergency=emergency, resumed=resumed, allocated=allocated)


def emergency_panel_apply(*, site: Site, alarm: bool, floors: list[str], reason: str) -> bool:
    """A fire panel's state (building.hooks.fire_panel_changed): start the alarm if none is
    in force; end it only if the panel started it (an operator's drill outlives the panel's
    retained "no alarm"). True if it started or ended one."""
    active = emergency_active(site=site)
    try:
        if alarm and active is None:
            emergency_start(site=site, floors=floors, reason=reason, via=EmergencySource.BUILDING)
            return True
        if not alarm and active is not None and active.started_via == EmergencySource.BUILDING:
            emergency_end(site=site, via=EmergencySource.BUILDING)
            return True
    except EmergencyRefused:  # an operator or the API got there first: theirs stands
        return False
    return False


def emergency_heartbeat_check(*, applied) -> bool:
    """Send to a refuge, or else stop, a robot that, while a fire alarm is in force, reports
    itself on a floor it covers, outside any resource and its waiting points, and was not
    dealt with yet; True if it was. Robot row locked (a heartbeat's receiver); no query unless
    an alarm is in force at its site."""
    robot = applied.robot
    if robot.site.fire_alarm_since is None or not applied.state_applied:
        return False
    if robot.status in (RobotStatus.IN_RESOURCE, RobotStatus.PAUSED) or robot.paused_by_operator:
        return False
    emergency = Emergency.objects.active().select_for_update().filter(site=robot.site).first()
    if emergency is None or robot.code in (*emergency.stopped_robots, *emergency.refuges):
        return False
    if not emergency.covers(floor_code_by_id(robot.site, robot.floor_id)):
        return False
    if not _stop(emergency, robot, None, applied.now, published=False):
        return False
    emergency.save(update_fields=["stopped_robots", "refuges"])
    return True


def _audit(emergency: Emergency, action: str, *, by, via: str) -> None:
    """Who started or ended the alarm, from where (the page or the REST API), on which floors."""
    entry_record(
        kind=Kind.OPERATOR_ACTION,
        obj=emergency,
        actor=by,
        site_id=emergency.site_id,
        object_repr=f"{emergency.get_kind_display()} at {emergency.site.code}",
        data={"action": action, "via": via, "floors": emergency.floors},
    )


def _floors_checked(site: Site, floors: list[str]) -> list[str]:
    known = site_map(site).floor_ids
    unknown = [code for code in floors if code not in known]
    if unknown:
        raise EmergencyRefused(f"Not a floor of {site}: {', '.join(unknown)}.", field="floors")
    return list(dict.fromkeys(floors))


def _robots_to_stop(site: Site, emergency: Emergency) -> list[Robot]:
    """The robots on its floors, but those inside a resource (they stop once out of it)."""
    robots = Robot.objects.filter(site=site).exclude(status=RobotStatus.IN_RESOURCE)
    return [
        robot
        for robot in robots.order_by("pk")
        if emergency.covers(floor_code_by_id(site, robot.floor_id))
    ]


def _stop(emergency: Emergency, robot: Robot, by, now: datetime, published=True) -> bool:
    """Send the locked robot to its nearest refuge, or else tell it to pause, unless an
    operator already holds it or it stands where robots wait for a lift, door or corridor
    (it is stopped once out); True if told, and recorded on `emergency` (not saved)."""
    if robot.paused_by_operator:
        return False
    refuge = _refuge_nearest(robot)
    if refuge is not None:
        emergency.refuges = {**emergency.refuges, robot.code: refuge}
        emergency.save(update_fields=["refuges"])  # read by the plan it is posted now
        plan_refuge_post(robot=robot, refuge=refuge, now=now)
        _tell_tasks(robot, REFUGE_NOTE.format(refuge=refuge), by, now)
    elif _in_a_lobby(robot):
        return False
    else:
        emergency.stopped_robots = [*emergency.stopped_robots, robot.code]
        _action_post(robot, OperatorActionKind.PAUSE)
        _tell_tasks(robot, HELD_NOTE, by, now)
    if published:
        robot_publish(robot=robot)
    return True


def _refuge_nearest(robot: Robot) -> str | None:
    """The refuge point of the robot's floor it reaches soonest without a lift, if any."""
    here = robot_position(robot)
    current = site_map(robot.site)
    floor = current.waypoints[here].floor
    router = router_for(robot.site)
    reachable = []
    for code in current.codes_of_kind(WaypointKind.REFUGE):
        if current.waypoints[code].floor != floor:
            continue
        leg = router.leg(here, code)
        if leg.path and not leg.rides:
            reachable.append((leg.seconds, code))
    return min(reachable)[1] if reachable else None


def _in_a_lobby(robot: Robot) -> bool:
    here = site_map(robot.site).waypoints[robot_position(robot)]
    return here.kind == WaypointKind.RESOURCE_WAIT


def _from_refuge(site: Site, code: str, by, now: datetime) -> None:
    """Post a robot the alarm sent to a refuge its plan without the refuge."""
    found = Robot.objects.filter(site=site, code=code).values_list("pk", flat=True).first()
    if found is None:
        return
    robot = robot_lock(found)
    robot_replan(robot=robot, now=now)
    _tell_tasks(robot, RESUMED_NOTE, by, now)
    robot_publish(robot=robot)


def _resume(site: Site, code: str, by, now: datetime) -> bool:
    """Tell a robot the alarm stopped to resume, unless an operator paused it meanwhile."""
    found = Robot.objects.filter(site=site, code=code).values_list("pk", flat=True).first()
    if found is None:
        return False
    robot = robot_lock(found)
    if robot.paused_by_operator:
        return False
    _action_post(robot, OperatorActionKind.RESUME)
    _tell_tasks(robot, RESUMED_NOTE, by, now)
    robot_publish(robot=robot)
    return True


def _action_post(robot: Robot, action: str) -> None:
    # The operator's key: a newer action withdraws an older one the robot has not acked.
    board_post(
        robot=robot,
        type=MessageType.ACTION,
        body=protocol.action_body(action=action),
        key=ACTION_KEY,
        supersede=True,
        robot_locked=True,
    )


def _tell_tasks(robot: Robot, note: str, by, now: datetime) -> None:
    for task in Task.objects.filter(robot=robot, status__in=ROUTE_STATUSES):
        task_record(
            task, old=task.status, at=now, cause=Cause.USER, robot=robot, user=by, note=note
        )


def _exit_reason(emergency: Emergency) -> str:
    """What a robot told to leave its lift shows (protocol words, not translated)."""
    return f"fire alarm: {emergency.reason}" if emergency.reason else "fire alarm"


def _alert_key(site: Site) -> str:
    return f"fire-alarm:{site.pk}"


def _alert_message(emergency: Emergency, by) -> Said:
    if emergency.floors:
        where = Said(gettext_noop("floors %(floors)s"), floors=", ".join(emergency.floors))
    else:
        where = Said(gettext_noop("every floor"))
    who = Said(gettext_noop(" by %(user)s"), user=by.get_username()) if by is not None else ""
    return Said(
        gettext_noop(
            "Fire alarm on %(where)s, started%(who)s%(reason)s. Robots there have stopped where "
            "they are; no robot is given a lift; new deliveries are accepted and wait for the "
            "all-clear."
        ),
        where=where,
        who=who,
        reason=f" ({emergency.reason})" if emergency.reason else "",
    )
