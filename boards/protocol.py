"""Everything a robot receives, built here and only here (docs/robot-protocol.md).

The heartbeat's answer, and the body of each message posted on a robot's board: other apps
decide what to post (the scheduler a plan, the resource controller a grant, an operator an
action) and call these builders with plain values, so the wire format has one home.
"""

from datetime import UTC, datetime

from boards.models import BoardMessage


def wire_time(moment: datetime) -> str:
    """UTC to the millisecond, as the protocol writes times: YYYY-MM-DDThh:mm:ss.sssZ."""
    return moment.astimezone(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def heartbeat_reply_wire(reply) -> dict:
    """The 200 answer to a heartbeat (boards.services.HeartbeatReply)."""
    return {
        "server_time": wire_time(reply.server_time),
        "heartbeat_interval": reply.heartbeat_interval,
        "map_version": reply.map_version,  # an addition: robots learn of a new map here
        "messages": [message_wire(message) for message in reply.messages],
    }


def message_wire(message: BoardMessage) -> dict:
    return {"id": message.public_id, "type": message.type, **message.body}


# --- Message bodies (what goes with "id" and "type") -------------------------------------------


def plan_body(*, version: int, stops: list[dict], tasks: dict[str, dict]) -> dict:
    """A `plan`: the robot's whole remaining route, applied only if `version` is newer."""
    return {"plan_version": version, "stops": stops, "tasks": tasks}


def plan_stop(*, task: str, stop: int, action: str, waypoint: str, via: list[str]) -> dict:
    """A pick-up or drop-off of a plan; `via`: elevator waiting points on the way there."""
    entry = {"task": task, "stop": stop, "action": action, "waypoint": waypoint}
    if via:
        entry["via"] = via
    return entry


def plan_dock_stop(*, waypoint: str, via: list[str], charge: bool = False) -> dict:
    """The one stop of a robot with nothing left to do (an addition to v1: action "dock");
    `"charge": true` (a further addition) when it is sent there to charge."""
    entry = {"action": "dock", "waypoint": waypoint}
    if via:
        entry["via"] = via
    if charge:
        entry["charge"] = True
    return entry


# Wrong PINs a robot accepts at a secure drop-off before it keeps the compartment locked.
SECURE_MAX_ATTEMPTS = 3


def plan_task(
    *,
    contents: str,
    sender: str,
    receiver: str,
    priority: str,
    pin: dict | None = None,
    badges: list[dict] = (),
) -> dict:
    """What a plan says about each of its tasks (`tasks`, by task code). A secure delivery
    (an addition) says how to check its PIN offline: `pin` is its salted slow hash; and, a
    further addition, `badges`: the salted slow hashes of the badges of the receiving unit's
    users, each with the `holder` to report as `opened_by` (robots/badges.py)."""
    entry = {"contents": contents, "sender": sender, "receiver": receiver, "priority": priority}
    if pin is not None:
        secure = {"pin": pin, "max_attempts": SECURE_MAX_ATTEMPTS, "badges": list(badges)}
        entry["secure"] = secure
    return entry


def grant_body(
    *, request: str, resource: str, lease: str, expires_at: datetime, to_floor: str | None
) -> dict:
    """`resource_grant`: enter until expires_at; `to_floor` (an addition) for elevators."""
    body = {
        "request": request,
        "resource": resource,
        "lease": lease,
        "expires_at": wire_time(expires_at),
    }
    if to_floor:
        body["to_floor"] = to_floor
    return body


def queued_body(*, request: str, resource: str, position: int) -> dict:
    """`resource_queued`: wait at the waiting point; position 1 is next."""
    return {"request": request, "resource": resource, "position": position}


def action_body(*, action: str) -> dict:
    """`action`: pause, resume or return_to_dock, from an operator."""
    return {"action": action}


def out_of_service_body(*, resource: str, since: datetime, reason: str) -> dict:
    """`resource_out_of_service` (an addition): nobody is granted `resource` until a
    `resource_in_service`; a robot that can go another way should."""
    return {"resource": resource, "since": wire_time(since), "reason": reason}


def in_service_body(*, resource: str) -> dict:
    """`resource_in_service` (an addition): `resource` is granted again, in queue order."""
    return {"resource": resource}


def elevator_at_floor_body(*, resource: str, lease: str, floor: str, doors: str) -> dict:
    """`elevator_at_floor` (an addition): the car of the robot's lease has stopped at `floor`
    with its doors `doors` ("open"): what a robot in the cabin cannot see for itself."""
    return {"resource": resource, "lease": lease, "floor": floor, "doors": doors}


def elevator_exit_body(
    *, resource: str, lease: str, floor: str | None, waypoint: str | None, reason: str
) -> dict:
    """`elevator_exit` (an addition): get out of the car of `lease` where it stops next,
    `floor` (its lobby `waypoint`) when the server drives the lift, and wait there for what
    the server says next; `reason`: words for people."""
    body = {"resource": resource, "lease": lease}
    if floor:
        body["floor"] = floor
    if waypoint:
        body["waypoint"] = waypoint
    body["reason"] = reason
    return body
