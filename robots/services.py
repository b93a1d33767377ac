"""Robots: credentials, the state they report, and presence (healthchecks' pattern).

A heartbeat stores when the robot will become unreachable and offline; the sweep flips only
rows whose deadline has passed, each flip claimed by a conditional UPDATE and recorded.

Whenever a heartbeat or the sweep changes what people see of a robot, it is reported to the
live pages (core.changes): at most once per heartbeat, and no query.
"""

from datetime import datetime

from django.db import transaction
from django.db.models import Q, QuerySet
from django.utils import timezone

from core import changes
from core.plainsql import row_update
from core.tokens import token_hash, token_new
from robots.badges import badge_hash
from robots.choices import Presence
from robots.hooks import presence_changed, token_issued
from robots.models import (
    PresenceChange,
    Robot,
    RobotActivity,
    RobotBoot,
    Site,
    SiteMembership,
    robot_activity,
)
from robots.selectors import available_robots_read

# A robot whose visible state does not change is still reported this often (on its next
# heartbeat after that), so the pages' "last seen" never lags by more than this.
LAST_SEEN_REFRESH_SECONDS = 10


def robot_authenticate(*, token: str, lock: bool = False) -> Robot | None:
    """The robot a bearer token belongs to, or None; with `lock`, its row locked for the rest
    of the transaction, as robot_lock does (every heartbeat)."""
    if lock:
        return _locking(Robot.objects.filter(token_hash=token_hash(token))).first()
    return Robot.objects.with_token(token).select_related("site").first()


@transaction.atomic
def robot_token_issue(*, robot: Robot) -> str:
    """Issue a new token for the robot, revoking the old one; returns it (show it once)."""
    token, hashed = token_new()
    robot.token_hash = hashed
    robot.token_issued_at = timezone.now()
    robot.save(update_fields=["token_hash", "token_issued_at"])
    token_issued(robot=robot)  # the push channel closes sockets opened with the old token
    return token


def robot_protocol_declare(
    *, robot: Robot, protocol: str, manufacturer: str = "", serial_number: str = ""
) -> None:
    """Say how the robot talks to the server (the site file does; so does the demo's setup)."""
    robot.protocol, robot.manufacturer, robot.serial_number = protocol, manufacturer, serial_number
    robot.full_clean(validate_unique=False, validate_constraints=False)
    robot.save(update_fields=["protocol", "manufacturer", "serial_number"])


def robot_lock(robot_id: int) -> Robot:
    """Lock the robot's row for the rest of the transaction: all its writes go through here.

    Only the robot's row (`of`), not the joined site's: heartbeats of different robots must
    not queue behind each other. And `no_key`: rows referring to the robot (a board message
    posted for it by another robot's transaction) may still be inserted meanwhile.
    """
    return _locking(Robot.objects).get(pk=robot_id)


def robot_lock_if_available(robot_id: int, site: Site) -> Robot | None:
    """Lock the site's robot as robot_lock does if it may still take a new task, else None.

    For the scheduler, which reads the candidates unlocked: an operator's Pause, a presence
    flip or a heartbeat reporting an error may have come in between.
    """
    locked = available_robots_read(site, robot_id=robot_id, lock=True)
    return locked[0] if locked else None


def _locking(robots: QuerySet[Robot]) -> QuerySet[Robot]:
    return robots.select_for_update(of=("self",), no_key=True).select_related("site")


def robot_heartbeat_record(
    *,
    robot: Robot,
    boot_id: str,
    seq: int,
    state: dict,
    now: datetime,
    interval: float | None = None,
    waited: float = 0.0,
) -> bool:
    """Record that a heartbeat arrived, answered with `interval` (core.overload); store its
    state only if it is the newest.

    Returns whether the state was applied. Call with the robot locked (robot_lock).
    """
    fresh = _heartbeat_is_newest(robot, boot_id, seq, now)
    shown, last_seen = robot_visible(robot), robot.last_seen_at
    doing = robot_activity(robot)
    if fresh:
        robot.apply_state(state, now)
        robot.boot_id, robot.seq = boot_id, seq
    previous = robot.mark_seen(now, interval, waited)
    # Every heartbeat of every robot writes these: plain SQL, compiled once (core/plainsql.py).
    row_update(robot, _HEARTBEAT_STATE_FIELDS if fresh else _HEARTBEAT_FIELDS)
    if previous is not None:
        _presence_record(robot, old=previous, new=Presence.ONLINE, at=now, cause="heartbeat")
    _activity_record(robot, previous=doing, at=now)
    if robot_visible(robot) != shown or last_seen_refresh_due(last_seen, now):
        robot_publish(robot=robot)
    return fresh


_HEARTBEAT_FIELDS = (*Robot.PRESENCE_FIELDS, "heartbeat_interval_told")
_HEARTBEAT_STATE_FIELDS = (*_HEARTBEAT_FIELDS, *Robot.STATE_FIELDS, "boot_id", "seq")


def robot_publish(*, robot: Robot) -> None:
    """Report the robot's state as it is now to the live pages (core.changes).

    No query: robot.site must be loaded (robot_lock and the sweep load it).
    """
    changes.changed(kind=changes.ROBOT, site_id=robot.site_id, subject=robot)


def robot_visible(robot: Robot) -> tuple:
    """What the pages show of a robot: a change of any of it is worth reporting."""
    battery = None if robot.battery is None else round(robot.battery * 100)
    return (
        robot.presence,
        robot.status,
        robot.floor_id,
        robot.waypoint_id,
        None if robot.x is None else round(robot.x, 2),
        None if robot.y is None else round(robot.y, 2),
        battery,
        robot.load,
        tuple(robot.errors or ()),
        robot.paused_by_operator,
        robot.fault_at is not None,
        robot.maintenance_since is not None,
    )


def last_seen_refresh_due(previous: datetime | None, now: datetime) -> bool:
    """Whether `now` starts a new refresh period since the robot was last seen."""
    if previous is None:
        return True
    period = LAST_SEEN_REFRESH_SECONDS
    return int(previous.timestamp() // period) != int(now.timestamp() // period)


def _heartbeat_is_newest(robot: Robot, boot_id: str, seq: int, now: datetime) -> bool:
    if boot_id == robot.boot_id:
        return robot.seq is None or seq > robot.seq
    if RobotBoot.objects.filter(robot=robot, boot_id=boot_id).exists():
        return False  # a boot the robot has since left behind: a late heartbeat
    RobotBoot.objects.create(robot=robot, boot_id=boot_id, first_seen_at=now)
    return True


@transaction.atomic
def robot_connection_lost(*, robot_id: int, graceful: bool, now: datetime | None = None) -> str:
    """A VDA 5050 vehicle's MQTT connection ended; returns its presence now.

    Broken (its last will, CONNECTIONBROKEN) is what a heartbeat robot's silence is: unreachable
    at once, offline at the deadline its last state set, and it keeps its tasks until then
    (elevator cabins have no network). A goodbye (OFFLINE: it is shutting down) is offline at
    once. Either way the flip goes through presence_changed like the sweep's.
    """
    now = now or timezone.now()
    robot = robot_lock(robot_id)
    if robot.last_seen_at is None:
        return robot.presence
    robot.unreachable_at = min(robot.unreachable_at, now)
    if graceful:
        robot.offline_at = min(robot.offline_at, now)
    new, doing = robot.presence_at(now), robot_activity(robot)
    old, robot.presence = robot.presence, new
    robot.save(update_fields=Robot.PRESENCE_FIELDS)
    if new != old:
        _presence_record(robot, old=old, new=new, at=now, cause=PresenceChange.Cause.CONNECTION)
        _activity_record(robot, previous=doing, at=now)
        robot_publish(robot=robot)
    return new


def presence_sweep(*, now: datetime | None = None) -> int:
    """Flip the presence of robots whose deadline has passed; returns how many flipped."""
    now = now or timezone.now()
    due = Robot.objects.filter(
        Q(presence=Presence.ONLINE, unreachable_at__lte=now)
        | Q(presence__in=[Presence.ONLINE, Presence.UNREACHABLE], offline_at__lte=now)
    ).select_related("site")
    return sum(presence_sweep_step(robot=robot, now=now) for robot in due)


@transaction.atomic
def presence_sweep_step(*, robot: Robot, now: datetime) -> int:
    """Flip one robot read by the sweep, unless its row changed since it was read."""
    new = robot.presence_at(now)
    claimed = Robot.objects.filter(
        pk=robot.pk, presence=robot.presence, last_seen_at=robot.last_seen_at
    ).update(presence=new)
    if not claimed:
        return 0  # a heartbeat or another sweeper got there first
    doing = robot_activity(robot)
    old, robot.presence = robot.presence, new
    _presence_record(robot, old=old, new=new, at=now, cause=PresenceChange.Cause.SWEEP)
    _activity_record(robot, previous=doing, at=now)
    robot_publish(robot=robot)
    return 1


def _presence_record(robot: Robot, *, old: str, new: str, at: datetime, cause: str) -> None:
    PresenceChange.objects.create(robot=robot, at=at, old=old, new=new, cause=cause)
    presence_changed(robot=robot, old=old, new=new, at=at)


def _activity_record(robot: Robot, *, previous: str, at: datetime) -> None:
    """Keep the activity history (reports' utilisation): one insert, only when it changed."""
    if robot_activity(robot) != previous:
        RobotActivity.objects.create(robot=robot, at=at, activity=robot_activity(robot))


def membership_badge_set(*, membership: SiteMembership, badge: str) -> None:
    """Keep the salted slow hash of the user's badge id (never the id), or forget it ("")."""
    badge = badge.strip()
    hashed = badge_hash(badge) if badge else None
    membership.badge_salt = hashed.salt if hashed else ""
    membership.badge_iterations = hashed.iterations if hashed else 0
    membership.badge_hash = hashed.hash if hashed else ""
    membership.save(update_fields=["badge_salt", "badge_iterations", "badge_hash"])
