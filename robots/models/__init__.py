from robots.models.alerts import Alert, AlertKind
from robots.models.fleet import PresenceChange, Robot, RobotBoot
from robots.models.leases import Lease
from robots.models.operator import OperatorAction
from robots.models.sites import Edge, Floor, Resource, ResourceWaypoint, Site, Waypoint

__all__ = [
    "Alert",
    "AlertKind",
    "Edge",
    "Floor",
    "Lease",
    "OperatorAction",
    "PresenceChange",
    "Resource",
    "ResourceWaypoint",
    "Robot",
    "RobotBoot",
    "Site",
    "Waypoint",
]
