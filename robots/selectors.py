"""Reads about robots that other apps need (the scheduler); they never reach further in."""

from robots.choices import Presence, RobotStatus
from robots.models import Robot, Site
from robots.sitemap import site_map

# Robots reporting these statuses are offered no new tasks.
UNAVAILABLE_STATUSES = [RobotStatus.ERROR, RobotStatus.PAUSED]
REACHABLE = [Presence.ONLINE, Presence.UNREACHABLE]

_codes_by_id: dict[int, tuple[int, dict[int, str]]] = {}  # site -> (map_version, id -> code)


def robots_for_allocation(*, site: Site) -> list[Robot]:
    """Robots that may be offered a new task (protocol v1, "Presence"), by code.

    Online or unreachable, not reporting an error or a pause, and with a reported battery
    level at or above the site's threshold (a robot that never reported has none).
    """
    robots = list(
        Robot.objects.filter(
            site=site,
            presence__in=REACHABLE,
            battery__isnull=False,
            battery__gte=site.battery_threshold,
        )
        .exclude(status__in=UNAVAILABLE_STATUSES)
        .order_by("code")
    )
    for robot in robots:
        robot.site = site
    return robots


def robot_position(robot: Robot) -> str:
    """The waypoint code a robot's route starts from: where it reported, else its dock.

    Reads the site's cached map, not the database (robot.site must be loaded).
    """
    return waypoint_code(robot.site, robot.waypoint_id or robot.dock_id)


def robot_dock(robot: Robot) -> str:
    return waypoint_code(robot.site, robot.dock_id)


def waypoint_code(site: Site, waypoint_id: int) -> str:
    current = site_map(site)
    version, codes = _codes_by_id.get(site.pk, (None, {}))
    if version != current.map_version:
        codes = {wp.id: wp.code for wp in current.waypoints.values()}
        _codes_by_id[site.pk] = (current.map_version, codes)
    return codes[waypoint_id]
