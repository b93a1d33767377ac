"""Publishing to websocket groups through Redis, for the robots' push channel (boards/push.py)
and the pages' live events (ui/live/publish.py).

A push is a courtesy, never the record: if Redis is down the change is still committed, pages
re-read their state when they reconnect and robots still heartbeat. So callers send through the
outbox (core/outbox.py), off the request's thread, and a Redis that stalls costs each publish at
most PUBLISH_TIMEOUT, without retries.
"""

import redis
from asgiref.sync import async_to_sync
from channels.layers import get_channel_layer
from channels_redis.pubsub import RedisPubSubChannelLayer
from django.conf import settings

from core.redisclient import TIMEOUT, redis_client

PUBLISH_TIMEOUT = TIMEOUT  # seconds to connect, and to send a publish and read its answer


def group_send(group: str, message: dict) -> None:
    """Send `message` to every consumer in `group`, now (not on commit)."""
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


def _redis() -> redis.Redis:
    return redis_client(settings.CHANNEL_LAYERS["default"]["CONFIG"]["hosts"][0])
