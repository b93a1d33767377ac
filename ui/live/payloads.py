"""Every live page event's payload, built here and only here (kinds: core/changes.py).

Built from the changed object alone, never a query: robots are published on the heartbeat's hot
path. The pages' re-read after a reconnect (ui/live/state.py) returns robots in the same shape,
so one piece of page code (static/js/live.js) applies both.
"""

from django.utils import timezone

from robots.choices import Presence, RobotStatus
from robots.mapcache import floor_code_by_id, site_map, waypoint_by_id
from robots.names import floor_label, place_label
from scheduling.choices import TaskStatus
from scheduling.deadlines import lateness_note


def robot_payload(robot) -> dict:
    """A robot as the fleet table and the floor map show it (robot.site must be loaded)."""
    floor = floor_code_by_id(robot.site, robot.floor_id)
    waypoint = waypoint_by_id(robot.site, robot.waypoint_id)
    x, y = robot.x, robot.y
    if (x is None or y is None) and waypoint is not None:
        x, y = waypoint.x, waypoint.y  # drawn at the waypoint it reported
    return {
        "code": robot.code,
        "presence": str(robot.presence),
        "presence_label": str(Presence(robot.presence).label),
        "status": str(robot.status),
        "status_label": str(RobotStatus(robot.status).label),
        "floor": floor,
        "floor_name": floor_label(site_map(robot.site), floor) if floor else "",
        "waypoint": waypoint.code if waypoint else None,
        "place": place_label(waypoint) if waypoint else None,
        "x": x,
        "y": y,
        "heading": robot.heading,
        "battery": None if robot.battery is None else round(robot.battery * 100),
        "load": robot.load,
        "capacity": robot.capacity,
        "errors": list(robot.errors or []),
        "paused_by_operator": robot.paused_by_operator,
        "held_after_fault": robot.fault_at is not None,
        "sent_to_charge": robot.sent_to_charge,
        "in_maintenance": robot.maintenance_since is not None,
        "last_seen_at": robot.last_seen_at.isoformat() if robot.last_seen_at else None,
    }


def task_payload(entry) -> dict:
    """A task's change: `entry` is the TaskTransition just recorded. Its status is the
    entry's, not the task's: moves held to the end of a heartbeat are told after the last."""
    return {
        "code": entry.task.code,
        "status": entry.new,
        "status_label": str(TaskStatus(entry.new).label),
        "old": entry.old,
        "cause": entry.cause,
        "robot": entry.robot.code if entry.robot else None,
        "at": entry.at.isoformat(),
    }


def etas_payload(tasks) -> dict:
    """New ETAs, as the deliveries page's ETA cell shows them (in the site's time zone)."""
    return {
        "tasks": [
            {
                "code": task.code,
                "eta": _local(task.eta),
                "eta_label": f"{timezone.localtime(task.eta):%H:%M}" if task.eta else "",
                "pickup_eta": _local(task.pickup_eta),
                "lateness": lateness_note(eta=task.eta, due_at=task.due_at),
            }
            for task in tasks
        ]
    }


def _local(at) -> str | None:
    return timezone.localtime(at).isoformat() if at else None


def lease_payload(lease, *, resource) -> dict:
    return {
        "id": lease.public_id,
        "resource": resource.code,
        "robot": lease.robot.code,
        "state": lease.state,
    }


def resource_payload(resource) -> dict:
    """A resource's service or building device changed: the page re-reads its panel."""
    return {"resource": resource.code, "in_service": resource.out_of_service_since is None}


def alert_payload(alert) -> dict:
    return {
        "id": alert.pk,
        "kind": alert.kind,
        "message": alert.text,
        "robot": alert.robot.code if alert.robot else None,
        "task": alert.task or None,
        "raised_at": alert.raised_at.isoformat(),
    }


def alert_acknowledged_payload(alert) -> dict:
    return {"id": alert.pk}
