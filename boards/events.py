"""Live pushes over Channels, sent after the transaction that caused them commits (except a
robot's wake-up from a transaction holding the robot's row lock: wake_now).

Two audiences: the pages watching a site (group "site-<id>", see the UI consumers) and a
robot's optional push channel (group "robot-<code>", protocol v1 "Push channel"), which only
ever carries a wake-up: board contents travel in heartbeat responses alone.

A push is a courtesy, never the record: if Redis is down the change is still committed and
pages re-read state when they reconnect, robots still heartbeat. So failures are logged,
not raised (robust on_commit).
"""

import functools
import hashlib
import logging

import redis
from asgiref.sync import async_to_sync
from channels.layers import get_channel_layer
from channels_redis.pubsub import RedisPubSubChannelLayer
from django.conf import settings
from django.db import transaction

logger = logging.getLogger(__name__)


def site_group(site_id: int) -> str:
    return f"site-{site_id}"


def robot_group(robot_code: str) -> str:
    return f"robot-{robot_code}"


def session_group(session_key: str) -> str:
    """The pages' sockets of one login session (the key itself stays out of Redis)."""
    return f"session-{hashlib.sha256(session_key.encode()).hexdigest()[:32]}"


def session_sockets_close(*, session_key: str) -> None:
    """Close the pages' sockets of a session that has just logged out (after commit, if any;
    like every push, a failure is logged and the logout goes ahead)."""
    message = {"type": "session.ended"}
    transaction.on_commit(lambda: _send(session_group(session_key), message), robust=True)


def robot_sockets_close_on_commit(*, robot_code: str, token_issued_at) -> None:
    """Close the robot's push sockets opened with a token older than the one just issued."""
    message = {"type": "robot.token_revoked", "issued_at": token_issued_at.isoformat()}
    transaction.on_commit(lambda: _send(robot_group(robot_code), message), robust=True)


def publish_on_commit(*, site_id: int, kind: str, data: dict) -> None:
    """Tell the pages watching site_id that `kind` happened (e.g. "robot", "task", "lease")."""
    message = {"type": "site.event", "kind": kind, "data": data}
    transaction.on_commit(lambda: _send(site_group(site_id), message), robust=True)


def wake_on_commit(*, robot_code: str, message_id: str) -> None:
    """Ask a robot with an open push channel to heartbeat now (it will find message_id)."""
    transaction.on_commit(lambda: _wake(robot_code, message_id), robust=True)


def wake_now(*, robot_code: str, message_id: str) -> None:
    """wake_on_commit, but at once: only for a caller holding the robot's row lock
    (robots.services.robot_lock). The heartbeat the wake causes waits for that lock, so it finds
    message_id committed, and the robot's trip to the server overlaps the rest of the
    transaction. If that rolls back, the robot has heartbeated once for nothing."""
    try:
        _wake(robot_code, message_id)
    except Exception:
        logger.exception("waking %s failed", robot_code)


def _wake(robot_code: str, message_id: str) -> None:
    _send(robot_group(robot_code), {"type": "robot.wake", "message": message_id})


def _send(group: str, message: dict) -> None:
    layer = get_channel_layer()
    if layer is None:
        return
    if isinstance(layer, RedisPubSubChannelLayer):
        _publish(layer, group, message)
    else:
        async_to_sync(layer.group_send)(group, message)


def _publish(layer: RedisPubSubChannelLayer, group: str, message: dict) -> None:
    """group_send of the Redis pub/sub layer, done synchronously on a pooled connection.

    From sync code (web workers, Celery), async_to_sync(layer.group_send) runs a new event loop
    per call, and the layer opens a new Redis connection per loop: about 12 ms a message,
    which under load is what pushed an overloaded server further behind. This is the same
    PUBLISH the layer makes (channels_redis 4.x, pinned: one shard, channel
    "<prefix>__group__<group>", the layer's own serializer); tests/ui/test_consumers.py
    checks that consumers receive it.
    """
    channel = f"{_layer_prefix()}__group__{group}"
    _redis().publish(channel, layer.serialize(message))


def _layer_prefix() -> str:
    return settings.CHANNEL_LAYERS["default"].get("CONFIG", {}).get("prefix", "asgi")


@functools.cache
def _redis() -> redis.Redis:
    # redis-py's pool notices a fork and opens new connections in the child.
    hosts = settings.CHANNEL_LAYERS["default"]["CONFIG"]["hosts"]
    return redis.Redis.from_url(hosts[0])
