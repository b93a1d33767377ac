"""Our deliveries, stations and robots as FHIR R4 resources (docs/integrators/fhir.md).

A Task's version is the number of entries in its delivery's history: every change of what the
Task shows (status, robot, hand-offs, cancellation) records one (scheduling.services.history),
so a version never changes once read. The robot's moment-to-moment state (in an elevator,
waiting for a door) changes no history: it is on the robot's Device, which has no versions.
"""

from datetime import datetime

from fhir_r4 import codes
from fhir_r4.orders import SITE_PREFIX, STATION_PREFIX
from robots.choices import Presence
from robots.models import Robot, Site, Waypoint
from scheduling.choices import Priority, StopAction, TaskStatus
from scheduling.models import CustodyKind, Task
from scheduling.services.custody import custody_words

ROBOT_PREFIX = "robot-"

# Our statuses onto FHIR's task statuses.
STATUSES = {
    TaskStatus.SCHEDULED: "requested",
    TaskStatus.DUE: "requested",
    TaskStatus.ASSIGNED: "accepted",
    TaskStatus.ACKNOWLEDGED: "accepted",
    TaskStatus.PICKED_UP: "in-progress",
    TaskStatus.DELIVERED: "in-progress",
    TaskStatus.COMPLETED: "completed",
    TaskStatus.CANCELLED: "cancelled",
    TaskStatus.FAILED: "failed",
}
# FHIR statuses onto the ones of ours they stand for (searches).
STATUSES_OF = {
    fhir: [ours for ours, to in STATUSES.items() if to == fhir] for fhir in set(STATUSES.values())
}
FHIR_PRIORITY = {Priority.ROUTINE: "routine", Priority.URGENT: "urgent", Priority.STAT: "stat"}

# businessStatus: where the delivery is, finer than its status.
BUSINESS_STATUSES = {
    "scheduled": "Waiting for its requested time",
    "waiting-for-robot": "Waiting for a robot",
    "robot-assigned": "A robot is assigned",
    "to-pickup": "The robot is on its way to the pick-up",
    "at-pickup": "The robot is at the pick-up, waiting to be loaded",
    "to-dropoff": "On board, on its way to the drop-off",
    "at-dropoff": "At the drop-off, waiting for the recipient",
    "returning": "Cancelled after pick-up: returning to the pick-up point",
    "delivered": "Handed over",
    "completed": "Completed",
    "cancelled": "Cancelled",
    "failed": "Failed",
}
_BUSINESS_OF_STATUS = {
    TaskStatus.SCHEDULED: "scheduled",
    TaskStatus.DUE: "waiting-for-robot",
    TaskStatus.ASSIGNED: "robot-assigned",
    TaskStatus.ACKNOWLEDGED: "to-pickup",
    TaskStatus.PICKED_UP: "to-dropoff",
    TaskStatus.DELIVERED: "delivered",
    TaskStatus.COMPLETED: "completed",
    TaskStatus.CANCELLED: "cancelled",
    TaskStatus.FAILED: "failed",
}
CUSTODY_OUTPUTS = {
    CustodyKind.LOADED: "loaded",
    CustodyKind.UNLOADED: "handed-over",
    CustodyKind.LOCKED_OUT: "locked-out",
    CustodyKind.MOVED_ON: "moved-on",
}


def instant(moment: datetime | None) -> str | None:
    return moment.isoformat() if moment is not None else None


def coding(system: str, code: str, display: str | None = None) -> dict:
    found = {"system": system, "code": code}
    if display:
        found["display"] = display
    return found


def etag(version: int) -> str:
    return f'W/"{version}"'


# --- Task -------------------------------------------------------------------------------------


def task_resource(task: Task) -> dict:
    """The delivery as a FHIR Task; `task` as fhir_r4.selectors.tasks_represented reads it."""
    order = getattr(task, "fhir_order", None)
    resource = {
        "resourceType": "Task",
        "id": task.code,
        "meta": {"versionId": str(task.version), "lastUpdated": instant(task.last_updated)},
        "identifier": _identifiers(task, order),
        "status": STATUSES[task.status],
        "businessStatus": _business_status(task),
        "intent": order.intent if order else "order",
        "priority": order.priority if order else FHIR_PRIORITY[task.priority],
        "description": task.contents,
        "authoredOn": instant(task.created_at),
        "lastModified": instant(task.last_updated),
        "location": site_reference(task.site),
        "restriction": {"period": _without_none(task.requested_time, task.due_at)},
        "input": _inputs(task),
    }
    reason = _status_reason(task, order)
    if reason:
        resource["statusReason"] = {"text": reason}
    if order is not None:
        for element, kept in (
            ("focus", order.focus),
            ("for", order.beneficiary),
            ("requester", order.requester),
        ):
            if kept:
                resource[element] = dict(kept)
    if task.robot is not None:
        resource["owner"] = device_reference(task.robot)
    period = _execution_period(task)
    if period:
        resource["executionPeriod"] = period
    outputs = [_custody_output(entry) for entry in task.custody.all()]
    if outputs:
        resource["output"] = outputs
    return resource


def _identifiers(task: Task, order) -> list[dict]:
    found = []
    if order is not None and order.identifier_value:
        ordered = {"system": order.identifier_system, "value": order.identifier_value}
        found.append({key: value for key, value in ordered.items() if value})
    found.append({"system": codes.TASK_CODE_SYSTEM, "value": task.code})
    return found


def _business_status_code(task: Task) -> str:
    """Where the delivery is: its status, or at a stop when its robot's newest event in its
    history was arriving there."""
    code = _BUSINESS_OF_STATUS[task.status]
    if task.return_trip and task.status == TaskStatus.PICKED_UP:
        return "returning"
    if task.newest_event_type == "arrived" and code in ("to-pickup", "to-dropoff"):
        stop = next((s for s in task.stops.all() if s.index == task.newest_event_stop), None)
        if stop is not None and stop.is_remaining:
            return "at-pickup" if stop.action == StopAction.PICKUP else "at-dropoff"
    return code


def _business_status(task: Task) -> dict:
    code = _business_status_code(task)
    words = BUSINESS_STATUSES[code]
    return {"coding": [coding(codes.BUSINESS_STATUS_SYSTEM, code, words)], "text": words}


def _status_reason(task: Task, order) -> str:
    if task.status == TaskStatus.CANCELLED and order is not None and order.cancel_reason:
        return order.cancel_reason
    if task.status in (TaskStatus.CANCELLED, TaskStatus.FAILED):
        return task.ended_note or ""
    return ""


def _without_none(start, end) -> dict:
    period = {"start": instant(start), "end": instant(end)}
    return {key: value for key, value in period.items() if value}


def _inputs(task: Task) -> list[dict]:
    stops = list(task.stops.all())
    if task.return_trip:  # its last stop is the way back, not what was ordered
        stops = stops[:-1]
    kinds = {StopAction.PICKUP: codes.PICKUP, StopAction.DROPOFF: codes.DROPOFF}
    inputs = [
        {"type": _input_type(kinds[s.action]), "valueReference": station_reference(s.waypoint)}
        for s in stops
    ]
    if task.secure:
        inputs.append({"type": _input_type(codes.SECURE), "valueBoolean": True})
    inputs.append({"type": _input_type(codes.RECIPIENT), "valueString": task.receiver})
    return inputs


def _input_type(code: str) -> dict:
    return {"coding": [coding(codes.INPUT_SYSTEM, code)]}


def _execution_period(task: Task) -> dict:
    """When the robot took the work on, and when it ended."""
    start = task.acknowledged_at or task.picked_up_at
    end = task.completed_at or task.cancelled_at or task.failed_at
    if task.status not in (TaskStatus.COMPLETED, TaskStatus.CANCELLED, TaskStatus.FAILED):
        end = None
    return _without_none(start, end)


def _custody_output(entry) -> dict:
    code = CUSTODY_OUTPUTS[entry.kind]
    return {
        "type": {"coding": [coding(codes.OUTPUT_SYSTEM, code, entry.get_kind_display())]},
        "valueAnnotation": {"time": instant(entry.at), "text": custody_words(entry)},
    }


def pin_output(pin: str) -> dict:
    """A secure delivery's PIN: in the answer to its creation only (only its hash is kept)."""
    return {"type": {"coding": [coding(codes.OUTPUT_SYSTEM, codes.PIN)]}, "valueString": pin}


# --- Location and Device ----------------------------------------------------------------------


def station_reference(waypoint: Waypoint) -> dict:
    return {
        "reference": f"Location/{STATION_PREFIX}{waypoint.pk}",
        "identifier": {"system": codes.STATION_SYSTEM, "value": waypoint.code},
        "display": waypoint.label,
    }


def site_reference(site: Site) -> dict:
    return {
        "reference": f"Location/{SITE_PREFIX}{site.pk}",
        "identifier": {"system": codes.SITE_SYSTEM, "value": site.code},
        "display": site.name or site.code,
    }


def device_reference(robot: Robot) -> dict:
    return {
        "reference": f"Device/{ROBOT_PREFIX}{robot.pk}",
        "identifier": {"system": codes.ROBOT_SYSTEM, "value": robot.code},
        "display": robot.name or robot.code,
    }


def station_resource(waypoint: Waypoint) -> dict:
    """A station as a Location: a room-like place on a floor of its site."""
    return {
        "resourceType": "Location",
        "id": f"{STATION_PREFIX}{waypoint.pk}",
        "identifier": [{"system": codes.STATION_SYSTEM, "value": waypoint.code}],
        "status": "active",
        "name": waypoint.label,
        "description": f"Floor {waypoint.floor.code}",
        "mode": "instance",
        "physicalType": {"coding": [coding(codes.PHYSICAL_TYPE_SYSTEM, "ro", "Room")]},
        "partOf": site_reference(waypoint.site),
    }


def site_resource(site: Site) -> dict:
    return {
        "resourceType": "Location",
        "id": f"{SITE_PREFIX}{site.pk}",
        "identifier": [{"system": codes.SITE_SYSTEM, "value": site.code}],
        "status": "active",
        "name": site.name or site.code,
        "mode": "instance",
        "physicalType": {"coding": [coding(codes.PHYSICAL_TYPE_SYSTEM, "si", "Site")]},
    }


def device_resource(robot: Robot) -> dict:
    """A robot as a Device: its state as last reported, not versioned."""
    online = robot.presence == Presence.ONLINE
    return {
        "resourceType": "Device",
        "id": f"{ROBOT_PREFIX}{robot.pk}",
        "identifier": [{"system": codes.ROBOT_SYSTEM, "value": robot.code}],
        "status": "active" if online else "inactive",
        "deviceName": [{"name": robot.name or robot.code, "type": "user-friendly-name"}],
        "type": {"text": "Autonomous delivery robot"},
        "location": site_reference(robot.site),
        "property": [
            _property("status", codes.ROBOT_STATUS_SYSTEM, robot.status),
            _property("presence", codes.PRESENCE_SYSTEM, robot.presence),
        ],
    }


def _property(name: str, system: str, value: str) -> dict:
    return {
        "type": {"coding": [coding(codes.DEVICE_PROPERTY_SYSTEM, name)]},
        "valueCode": [{"coding": [coding(system, value)]}],
    }
