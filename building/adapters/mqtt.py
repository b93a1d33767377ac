"""The MQTT adapter: a building integrator's lift and door controller (docs/building-devices.md).

Topics, under settings.BUILDING_MQTT_PREFIX and the site's code:

    <prefix>/<site>/lift_requests/<lift>    the server publishes   (Open-RMF LiftRequest)
    <prefix>/<site>/lift_states/<lift>      the controller publishes (Open-RMF LiftState)
    <prefix>/<site>/door_requests/<door>    the server publishes   (Open-RMF DoorRequest)
    <prefix>/<site>/door_states/<door>      the controller publishes (Open-RMF DoorState)
    <prefix>/<site>/fire_panel              the fire panel's gateway publishes (FirePanel,
                                            ours: Open-RMF has no such message)

Payloads are JSON objects with Open-RMF's field names and numeric constants. The bridge
(`manage.py building_bridge`, the Procfile's `building`) publishes each new request (QoS 1,
retained, so a controller that reconnects reads the latest) and applies every state it reads
through building.services.device_report; a state that is not valid is logged and counted,
and changes nothing.
"""

import json
import logging
from datetime import UTC, datetime

from building.choices import DoorState, Motion

logger = logging.getLogger(__name__)

# Open-RMF's constants (rmf_lift_msgs, rmf_door_msgs).
DOOR_CODES = {DoorState.CLOSED: 0, DoorState.MOVING: 1, DoorState.OPEN: 2}
DOOR_BY_CODE = {code: state for state, code in DOOR_CODES.items()}
MOTION_BY_CODE = {0: Motion.STOPPED, 1: Motion.UP, 2: Motion.DOWN, 3: Motion.UNKNOWN}
REQUEST_END_SESSION, REQUEST_AGV_MODE = 0, 1
# LiftState.current_mode: 0 UNKNOWN, 1 HUMAN, 2 AGV, 3 FIRE, 4 OFFLINE, 5 EMERGENCY
LIFT_FAULT_MODES = {3: "fire", 4: "offline", 5: "emergency"}
# DoorMode: 3 OFFLINE, 4 UNKNOWN
DOOR_FAULT_MODES = {3: "offline", 4: "unknown"}
REQUESTER = "hospital_delivery"


class StateInvalid(ValueError):
    """A state message that does not follow the documented payload."""


def topic(prefix: str, site: str, kind: str, name: str) -> str:
    return f"{prefix}/{site}/{kind}/{name}"


def stamp(moment: datetime) -> dict:
    """builtin_interfaces/Time: seconds and nanoseconds since the epoch."""
    seconds = moment.timestamp()
    return {"sec": int(seconds), "nanosec": int((seconds % 1) * 1e9)}


def lift_request(*, name: str, session: str, floor: str | None, door: str, now: datetime) -> dict:
    """A LiftRequest: in AGV mode (doors held open while stopped) to `floor` for `session`
    (or for an operator holding the doors), else END_SESSION: nobody is served."""
    held = bool(session) or door == DoorState.OPEN
    return {
        "lift_name": name,
        "request_time": stamp(now),
        "session_id": session or (REQUESTER if held else ""),
        "request_type": REQUEST_AGV_MODE if held else REQUEST_END_SESSION,
        "destination_floor": floor or "",
        "door_state": DOOR_CODES[DoorState.OPEN if door == DoorState.OPEN else DoorState.CLOSED],
    }


def door_request(*, name: str, door: str, now: datetime) -> dict:
    """A DoorRequest: open or closed."""
    mode = DoorState.OPEN if door == DoorState.OPEN else DoorState.CLOSED
    return {
        "door_name": name,
        "request_time": stamp(now),
        "requester_id": REQUESTER,
        "requested_mode": {"value": DOOR_CODES[mode]},
    }


def lift_state_read(payload: bytes, name: str) -> dict:
    """The fields of a LiftState for building.services.Report; StateInvalid if it is not one."""
    data = _object(payload)
    if data.get("lift_name") != name:
        raise StateInvalid(f"lift_name: expected {name!r}")
    floor = _field(data, "current_floor", str)
    door = DOOR_BY_CODE.get(_field(data, "door_state", int))
    motion = MOTION_BY_CODE.get(_field(data, "motion_state", int))
    mode = data.get("current_mode", 2)
    if door is None or motion is None or not isinstance(mode, int) or isinstance(mode, bool):
        raise StateInvalid("door_state, motion_state or current_mode out of range")
    session = data.get("session_id", "")
    if not isinstance(session, str):
        raise StateInvalid("session_id: not a string")
    fault = LIFT_FAULT_MODES.get(mode, "")
    return {"floor": floor, "door": door, "motion": motion, "session": session, "fault": fault}


def door_state_read(payload: bytes, name: str) -> dict:
    data = _object(payload)
    if data.get("door_name") != name:
        raise StateInvalid(f"door_name: expected {name!r}")
    mode = data.get("current_mode")
    value = mode.get("value") if isinstance(mode, dict) else None
    if not isinstance(value, int) or isinstance(value, bool):
        raise StateInvalid("current_mode.value: not an integer")
    if value in DOOR_FAULT_MODES:
        return {"door": DoorState.CLOSED, "fault": DOOR_FAULT_MODES[value]}
    if value not in DOOR_BY_CODE:
        raise StateInvalid("current_mode.value out of range")
    return {"door": DOOR_BY_CODE[value], "fault": ""}


def fire_panel_read(payload: bytes) -> dict:
    """A FirePanel state: {"alarm": bool, "floors": [codes] (empty or left out: every
    floor), "reason": str (optional)}; StateInvalid if it is not one. Floors are checked
    against the site by the bridge."""
    data = _object(payload)
    alarm = data.get("alarm")
    if not isinstance(alarm, bool):
        raise StateInvalid("alarm: missing or not true/false")
    floors = data.get("floors", [])
    if not isinstance(floors, list) or not all(isinstance(code, str) for code in floors):
        raise StateInvalid("floors: not a list of floor codes")
    reason = data.get("reason", "")
    if not isinstance(reason, str):
        raise StateInvalid("reason: not a string")
    return {"alarm": alarm, "floors": floors, "reason": reason}


def _object(payload: bytes) -> dict:
    try:
        data = json.loads(payload)
    except (ValueError, UnicodeDecodeError) as error:
        raise StateInvalid(f"not JSON: {error}") from None
    if not isinstance(data, dict):
        raise StateInvalid("not a JSON object")
    return data


def _field(data: dict, name: str, kind: type):
    value = data.get(name)
    if not isinstance(value, kind) or isinstance(value, bool):
        raise StateInvalid(f"{name}: missing or not a {kind.__name__}")
    return value


def utcnow() -> datetime:
    return datetime.now(UTC)
