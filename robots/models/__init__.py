from robots.models.alerts import Alert, AlertKind
from robots.models.fleet import PresenceChange, Robot, RobotBoot
from robots.models.map import Edge, Floor, Resource, ResourceWaypoint, Site, Waypoint
from robots.models.membership import SiteMembership

__all__ = [
    "Alert",
    "AlertKind",
    "Edge",
    "Floor",
    "PresenceChange",
    "Resource",
    "ResourceWaypoint",
    "Robot",
    "RobotBoot",
    "Site",
    "SiteMembership",
    "Waypoint",
]
