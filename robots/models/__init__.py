from robots.models.alerts import Alert, AlertKind
from robots.models.fleet import PresenceChange, Robot, RobotActivity, RobotBoot, robot_activity
from robots.models.map import Edge, Floor, Resource, ResourceWaypoint, Site, Waypoint

__all__ = [
    "Alert",
    "AlertKind",
    "Edge",
    "Floor",
    "PresenceChange",
    "Resource",
    "ResourceWaypoint",
    "Robot",
    "RobotActivity",
    "RobotBoot",
    "Site",
    "Waypoint",
    "robot_activity",
]
