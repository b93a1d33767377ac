"""The message board: what the server posts for each robot, and heartbeats that carry it.

Every write for one robot happens with that robot's row locked (robots.services.robot_lock),
so concurrent or duplicated heartbeats of one robot are applied one after the other.
"""

from dataclasses import dataclass, field
from datetime import datetime

from django.conf import settings
from django.db import transaction
from django.db.models import QuerySet
from django.utils import timezone

from boards.heartbeat_sql import board_message_ack, board_pending_of
from boards.hooks import heartbeat_applied
from boards.models import BoardMessage, RobotEvent, RobotRequest
from boards.push import wake_now, wake_on_commit
from core import memo
from core.overload import heartbeat_interval, heartbeat_interval_spread
from robots.choices import RobotStatus
from robots.models import Robot
from robots.selectors import robots_heartbeating
from robots.services import robot_heartbeat_record


class HeartbeatRejected(Exception):
    """Raised by a heartbeat_applied receiver to refuse a heartbeat; errors by field path."""

    def __init__(self, errors: dict[str, list[str] | str]):
        super().__init__(errors)
        self.errors = errors


@dataclass
class AppliedHeartbeat:
    """What one heartbeat changed, handed to heartbeat_applied receivers."""

    robot: Robot
    now: datetime
    state_applied: bool
    # The robot's software started again (a boot_id not seen before, and this is its newest
    # heartbeat): it may have lost its plan (scheduling.services.plans.plan_restore).
    new_boot: bool = False
    acked: list[BoardMessage] = field(default_factory=list)
    events: list[RobotEvent] = field(default_factory=list)
    requests: list[RobotRequest] = field(default_factory=list)
    # Request id -> its index in the heartbeat's `requests` list (first occurrence), so a
    # receiver can name the field it refuses ("requests[2].to_floor").
    request_index: dict[str, int] = field(default_factory=dict)
    # Event id -> its index in the heartbeat's `events` list (first occurrence), likewise
    # ("events[3].task").
    event_index: dict[str, int] = field(default_factory=dict)


@dataclass
class HeartbeatReply:
    server_time: datetime
    heartbeat_interval: float
    map_version: int
    messages: list[BoardMessage]


@transaction.atomic(savepoint=False)  # if it raises, the caller's whole transaction rolls back
def heartbeat_apply(
    *, robot: Robot, heartbeat: dict, now: datetime | None = None, waited: float = 0.0
):
    """Apply one validated heartbeat (boards.serializers.HeartbeatSerializer) of a robot whose
    row the caller locked in its transaction (robots.services.robot_lock, or the heartbeat
    view's RobotTokenLockingAuthentication); `waited`: seconds it waited for a web worker
    (core.overload.request_waited).

    Acks and events are applied even when the heartbeat is stale (an older seq of the
    current boot, or an earlier boot): they are idempotent. Its state is applied only if it
    is the newest the server has seen.
    """
    now = now or timezone.now()
    told, interval = _intervals(robot, heartbeat, now, waited)
    acked = board_ack(robot=robot, public_ids=heartbeat["acks"], now=now)
    events = _events_record(robot, heartbeat, now)
    requests = _requests_record(robot, heartbeat["requests"], now)
    boot_before = robot.boot_id
    state_applied = robot_heartbeat_record(
        robot=robot,
        boot_id=heartbeat["boot_id"],
        seq=heartbeat["seq"],
        state=heartbeat["state"],
        now=now,
        interval=interval,
        waited=waited,
    )
    applied = AppliedHeartbeat(
        robot=robot,
        now=now,
        state_applied=state_applied,
        new_boot=state_applied and robot.boot_id != boot_before and bool(boot_before),
        acked=acked,
        events=events,
        requests=requests,
        request_index=_index_of_each_id(heartbeat["requests"]),
        event_index=_index_of_each_id(heartbeat["events"]),
    )
    with memo.scope():  # the receivers may move several tasks: their reads shared (core.memo)
        heartbeat_applied(applied=applied)
    messages = board_pending(robot=robot)
    return HeartbeatReply(
        server_time=now,
        heartbeat_interval=told if messages else interval,
        map_version=robot.site.map_version,
        messages=messages,
    )


def _intervals(robot: Robot, heartbeat: dict, now: datetime, waited: float) -> tuple[float, float]:
    """(the interval the load allows, the one for this heartbeat): the second is longer while
    the robot is idle with the push channel open, and its presence follows it even when the
    answer then tells it the first (messages came meanwhile): never flipped for it. Each is
    spread over robots when longer than the site's (core.overload)."""
    base = robot.site.heartbeat_interval
    told = heartbeat_interval(
        base=base,
        previous=robot.heartbeat_interval_told,
        waited=waited,
        robots=robots_heartbeating(),
        capacity=settings.HEARTBEAT_CAPACITY,
        longest=settings.HEARTBEAT_INTERVAL_MAX,
    )
    robot.heartbeat_interval_told = told
    intervals = (told, _interval_idle(told, heartbeat))
    spread = (heartbeat_interval_spread(robot.pk, each, base=base, now=now) for each in intervals)
    return tuple(spread)


def _interval_idle(told: float, heartbeat: dict) -> float:
    """The interval for a robot idle with its push channel open: HEARTBEAT_IDLE_INTERVAL if
    longer than `told`, else `told`.

    Idle: the validated `heartbeat` says `push` (the robot holds the push channel), status
    idle, nothing on board, and carries no events or requests. Such a robot has nothing to
    report until the server posts it something, and the push channel wakes it at once when it
    does, so its heartbeats only say it is still there: at the defaults, a fleet waiting at its
    docks sends a fifth of the heartbeats. heartbeat_apply tells `told` instead when its answer
    carries messages: the robot has work coming."""
    if not settings.HEARTBEAT_IDLE_INTERVAL or not heartbeat.get("push"):
        return told
    state = heartbeat["state"]
    if state["status"] != RobotStatus.IDLE or state["load"]:
        return told
    if heartbeat["events"] or heartbeat["requests"]:
        return told
    return max(told, float(settings.HEARTBEAT_IDLE_INTERVAL))


def _events_record(robot: Robot, heartbeat: dict, now: datetime) -> list[RobotEvent]:
    """Store the events not seen before, in the robot's order; return only those."""
    unseen = _unseen(robot, RobotEvent, "event_id", heartbeat["events"])
    if not unseen:  # most heartbeats
        return []
    return RobotEvent.objects.bulk_create(
        [
            RobotEvent(
                robot=robot,
                event_id=event_id,
                type=event["type"],
                at=event.get("at"),
                task=event.get("task", ""),
                stop=event.get("stop"),
                resource=event.get("resource", ""),
                data=event["raw"],
                received_at=now,
                boot_id=heartbeat["boot_id"],
                seq=heartbeat["seq"],
            )
            for event_id, event in unseen
        ]
    )


def _requests_record(robot: Robot, requests: list[dict], now: datetime) -> list[RobotRequest]:
    """Store the acquire/release requests not seen before; return only those."""
    unseen = _unseen(robot, RobotRequest, "request_id", requests)
    if not unseen:
        return []
    return RobotRequest.objects.bulk_create(
        [
            RobotRequest(
                robot=robot,
                request_id=request_id,
                type=request["type"],
                resource=request["resource"],
                to_floor=request.get("to_floor", ""),
                data=request["raw"],
                received_at=now,
            )
            for request_id, request in unseen
        ]
    )


def _unseen(robot: Robot, model, id_field: str, items: list[dict]) -> list[tuple[str, dict]]:
    """(id, item) of the items whose id the robot never sent before, first of each id, in order.

    Race-free because the robot's row is locked: its heartbeats are applied one at a time.
    """
    incoming = _first_of_each_id(items)
    if not incoming:
        return []
    stored = model.objects.filter(robot_id=robot.pk, **{f"{id_field}__in": list(incoming)})
    seen = set(stored.values_list(id_field, flat=True))
    return [(item_id, item) for item_id, item in incoming.items() if item_id not in seen]


def _first_of_each_id(items: list[dict]) -> dict[str, dict]:
    first: dict[str, dict] = {}
    for item in items:
        first.setdefault(item["id"], item)
    return first


def _index_of_each_id(items: list[dict]) -> dict[str, int]:
    index: dict[str, int] = {}
    for position, item in enumerate(items):
        index.setdefault(item["id"], position)
    return index


def board_pending(*, robot: Robot) -> list[BoardMessage]:
    """Messages on the robot's board, oldest first: what every heartbeat response carries."""
    return board_pending_of(robot.pk)  # every heartbeat reads it: plain SQL


def board_ack(*, robot: Robot, public_ids: list[str], now: datetime) -> list[BoardMessage]:
    """Take acked messages off the board; returns those this call took off (others ignored)."""
    if not public_ids:
        return []
    if len(public_ids) == 1:  # nearly every ack: a plan, an action
        return _ack_one(robot, BoardMessage.pk_from_public_id(public_ids[0]), now)
    acked = list(BoardMessage.objects.pending().filter(robot=robot).with_public_ids(public_ids))
    if acked:
        BoardMessage.objects.filter(pk__in=[m.pk for m in acked]).update(acked_at=now)
        for message in acked:
            message.acked_at = now
    return acked


def _ack_one(robot: Robot, pk: int | None, now: datetime) -> list[BoardMessage]:
    message = None if pk is None else board_message_ack(robot.pk, pk, now)
    return [] if message is None else [message]


def board_post(
    *,
    robot: Robot,
    type: str,
    body: dict,
    key: str = "",
    supersede: bool = False,
    robot_locked: bool = False,
) -> BoardMessage:
    """Post a message for a robot; it goes out in every heartbeat response until acked.

    With supersede, pending messages of the same robot and key are withdrawn first (a newer
    plan replaces an unacked older one). A robot with an open push channel is woken once the
    transaction commits, or at once if the caller holds the robot's row lock (`robot_locked`;
    boards.push.wake_now).
    """
    now = timezone.now()
    if supersede:
        board_withdraw(
            messages=BoardMessage.objects.pending().filter(robot=robot, key=key),
            reason="superseded",
            now=now,
        )
    message = BoardMessage.objects.create(robot=robot, type=type, body=body, key=key, posted_at=now)
    wake = wake_now if robot_locked else wake_on_commit
    wake(robot_code=robot.code, message_id=message.public_id)
    return message


def board_withdraw(*, messages, reason: str, now: datetime | None = None) -> int:
    """Take pending messages off the board without the robot acking them; returns how many."""
    pks = messages.values("pk") if isinstance(messages, QuerySet) else [m.pk for m in messages]
    return (
        BoardMessage.objects.pending()
        .filter(pk__in=pks)
        .update(withdrawn_at=now or timezone.now(), withdraw_reason=reason)
    )
