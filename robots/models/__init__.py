from robots.models.alerts import Alert, AlertKind
from robots.models.emergency import Emergency
from robots.models.fleet import (
    PresenceChange,
    Robot,
    RobotActivity,
    RobotBoot,
    robot_activity,
)
from robots.models.map import Edge, Floor, Resource, ResourceWaypoint, Site, Waypoint
from robots.models.membership import SiteMembership

__all__ = [
    "Alert",
    "AlertKind",
    "Edge",
    "Emergency",
    "Floor",
    "PresenceChange",
    "Resource",
    "ResourceWaypoint",
    "Robot",
    "RobotActivity",
    "RobotBoot",
    "Site",
    "SiteMembership",
    "Waypoint",
    "robot_activity",
]
