"""Reads about robots: for the other apps (the scheduler), which never reach further in, and
for the pages (sites, the fleet, open alerts)."""

import math
import time

from django.db import connection
from django.db.models import QuerySet

from core.overload import COUNT_SECONDS
from core.plainsql import column, columns, loaded, table
from robots.choices import Presence, RobotStatus
from robots.mapcache import waypoint_by_id
from robots.models import Alert, Emergency, Robot, Site, SiteMembership

# Robots reporting these statuses are offered no new tasks.
UNAVAILABLE_STATUSES = [RobotStatus.ERROR, RobotStatus.PAUSED]
REACHABLE = [Presence.ONLINE, Presence.UNREACHABLE]


def robots_for_allocation(*, site: Site) -> list[Robot]:
    """Robots that may be offered a new task (protocol v1, "Presence"), by code.

    Online or unreachable, not reporting an error or a pause, not held by an operator (Pause
    or Return to dock, until Resume) nor after a fault (until an operator resolves it), not
    sent to charge (until charged), not in maintenance (until returned to service), and with
    a reported battery level at or above the site's threshold (a robot that never reported
    has none).
    """
    return available_robots_read(site)


def available_robots_read(
    site: Site, *, robot_id: int | None = None, lock: bool = False
) -> list[Robot]:
    """available_robots of the site by code, each with `site` set; only the robot `robot_id`
    if given, its row locked as robots.services.robot_lock locks it if `lock`.

    Every allocation reads them, in the nurse's request when it is alone on its site: on
    PostgreSQL one statement of plain SQL built once (core/plainsql.py), which Django would
    compile again on every call for these wide rows; elsewhere the queryset. Both give the same
    robots (tests/robots/test_available_sql.py).
    """
    if connection.vendor != "postgresql":
        robots = available_robots(site.pk, site.battery_threshold)
        if robot_id is not None:
            robots = robots.filter(pk=robot_id)
        if lock:
            robots = robots.select_for_update(of=("self",), no_key=True)
        found = list(robots.order_by("code"))
    else:
        sql, params = _AVAILABLE, [site.pk, *_REACHABLE, site.battery_threshold, *_UNAVAILABLE]
        if robot_id is not None:
            sql, params = f"{sql} AND {column(Robot, 'id', 'r')} = %s", [*params, robot_id]
        sql += " FOR NO KEY UPDATE" if lock else f" ORDER BY {column(Robot, 'code', 'r')}"
        with connection.cursor() as cursor:
            cursor.execute(sql, params)
            found = [loaded(Robot, row) for row in cursor.fetchall()]
    for robot in found:
        robot.site = site
    return found


def available_robots(site_id: int, threshold: float) -> QuerySet[Robot]:
    """The site's robots that may be offered a new task (see robots_for_allocation), for its
    battery threshold. Its twin in plain SQL, _AVAILABLE, says the same."""
    return Robot.objects.filter(
        site_id=site_id,
        presence__in=REACHABLE,
        paused_by_operator=False,
        fault_at__isnull=True,
        sent_to_charge=False,
        maintenance_since__isnull=True,
        battery__isnull=False,
        battery__gte=threshold,
    ).exclude(status__in=UNAVAILABLE_STATUSES)


_REACHABLE = [str(presence) for presence in REACHABLE]
_UNAVAILABLE = [str(status) for status in UNAVAILABLE_STATUSES]
# available_robots' conditions in its order; a NULL battery fails `>=` as it fails __gte.
_AVAILABLE = (
    f"SELECT {columns(Robot, 'r')} FROM {table(Robot)} r "
    f"WHERE {column(Robot, 'site', 'r')} = %s "
    f"AND {column(Robot, 'presence', 'r')} IN (%s, %s) "
    f"AND NOT {column(Robot, 'paused_by_operator', 'r')} "
    f"AND {column(Robot, 'fault_at', 'r')} IS NULL "
    f"AND NOT {column(Robot, 'sent_to_charge', 'r')} "
    f"AND {column(Robot, 'maintenance_since', 'r')} IS NULL "
    f"AND {column(Robot, 'battery', 'r')} >= %s "
    f"AND {column(Robot, 'status', 'r')} NOT IN (%s, %s)"
)


def robots_heartbeating() -> int:
    """Robots not offline, every site's: those whose heartbeats the web nodes take. Counted at
    most every COUNT_SECONDS per process: every heartbeat asks."""
    now = time.monotonic()
    if now - _count["at"] >= COUNT_SECONDS:
        _count["robots"] = Robot.objects.exclude(presence=Presence.OFFLINE).count()
        _count["at"] = now
    return _count["robots"]


def robots_heartbeating_forget() -> None:
    """Count again at the next heartbeat (tests)."""
    _count["at"] = -math.inf


_count = {"robots": 0, "at": -math.inf}


def robot_position(robot: Robot) -> str:
    """The waypoint code a robot's route starts from: where it reported, else its dock.

    Reads the site's cached map, not the database (robot.site must be loaded).
    """
    return waypoint_code(robot.site, robot.waypoint_id or robot.dock_id)


def robot_dock(robot: Robot) -> str:
    return waypoint_code(robot.site, robot.dock_id)


def waypoint_code(site: Site, waypoint_id: int) -> str:
    waypoint = waypoint_by_id(site, waypoint_id)
    if waypoint is None:
        raise KeyError(waypoint_id)
    return waypoint.code


def sites_all() -> list[Site]:
    return list(Site.objects.order_by("code"))


def alerts_open() -> QuerySet[Alert]:
    """Open alerts, newest first (lazy: one query when listed)."""
    return Alert.objects.open().select_related("site", "robot")


def emergency_active(*, site: Site) -> Emergency | None:
    """The fire alarm in force at the site, if any."""
    return Emergency.objects.active().filter(site=site).select_related("started_by").first()


def fleet_snapshot(*, site: Site) -> list[Robot]:
    """The site's robots by code, in one query (their site set, so the map lookups need none)."""
    robots = list(Robot.objects.filter(site=site).order_by("code"))
    for robot in robots:
        robot.site = site
    return robots


def unit_badges(*, station_ids) -> list[dict]:
    """What a robot needs to recognise offline the badges of the users of these stations'
    units (robots/badges.py): one hash each, with the username it reports as `opened_by`."""
    members = (
        SiteMembership.objects.filter(unit_id__in=list(station_ids))
        .exclude(badge_hash="")
        .select_related("user")
        .order_by("user__username")
    )
    return [member.badge.wire(member.user.get_username()) for member in members]
