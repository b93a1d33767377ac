"""Robots as the live pages receive them (boards.events, kind "robot").

Built from the robot row (with its site) and the site's cached map only, never a query: the
heartbeat publishes it on its hot path. The pages' re-read after a reconnect returns the same
shape (robots.selectors.fleet_snapshot), so one piece of page code applies both.
"""

from datetime import datetime

from robots.choices import Presence, RobotStatus
from robots.models import Robot
from robots.sitemap import floor_code_by_id, site_map, waypoint_by_id

# A robot whose visible state does not change is still re-published this often (on its next
# heartbeat after that), so the pages' "last seen" never lags by more than this.
LAST_SEEN_REFRESH_SECONDS = 10


def robot_wire(robot: Robot) -> dict:
    floor = floor_code_by_id(robot.site, robot.floor_id)
    waypoint = waypoint_by_id(robot.site, robot.waypoint_id)
    x, y = robot.x, robot.y
    if (x is None or y is None) and waypoint is not None:
        x, y = waypoint.x, waypoint.y  # drawn at the waypoint it reported
    return {
        "code": robot.code,
        "presence": str(robot.presence),
        "presence_label": Presence(robot.presence).label,
        "status": str(robot.status),
        "status_label": RobotStatus(robot.status).label,
        "floor": floor,
        "floor_name": site_map(robot.site).floor_names.get(floor, "") if floor else "",
        "waypoint": waypoint.code if waypoint else None,
        "place": waypoint.label if waypoint else None,
        "x": x,
        "y": y,
        "heading": robot.heading,
        "battery": _percent(robot.battery),
        "load": robot.load,
        "capacity": robot.capacity,
        "errors": list(robot.errors or []),
        "paused_by_operator": robot.paused_by_operator,
        "last_seen_at": robot.last_seen_at.isoformat() if robot.last_seen_at else None,
    }


def robot_visible(robot: Robot) -> tuple:
    """What the pages show of a robot: a change of any of it is worth an event."""
    return (
        robot.presence,
        robot.status,
        robot.floor_id,
        robot.waypoint_id,
        _rounded(robot.x),
        _rounded(robot.y),
        _percent(robot.battery),
        robot.load,
        tuple(robot.errors or ()),
        robot.paused_by_operator,
    )


def last_seen_refresh_due(previous: datetime | None, now: datetime) -> bool:
    """Whether `now` starts a new refresh period since the robot was last seen."""
    if previous is None:
        return True
    period = LAST_SEEN_REFRESH_SECONDS
    return int(previous.timestamp() // period) != int(now.timestamp() // period)


def _percent(fraction: float | None) -> int | None:
    return None if fraction is None else round(fraction * 100)


def _rounded(metres: float | None) -> float | None:
    return None if metres is None else round(metres, 2)
