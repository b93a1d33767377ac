"""The server's own small keys in Redis (the sweeps' last runs, the allocation messages waiting
per site): one client per process, with short timeouts and no retries, since every such key is
a courtesy that a sweep or a timeout makes up for when Redis stalls."""

import functools

import redis
from django.conf import settings
from redis.backoff import NoBackoff
from redis.retry import Retry

TIMEOUT = 0.5  # seconds to connect, and to send a command and read its answer


@functools.cache
def redis_client() -> redis.Redis:
    # redis-py's pool notices a fork and opens new connections in the child.
    return redis.Redis.from_url(
        settings.REDIS_URL,
        socket_timeout=TIMEOUT,
        socket_connect_timeout=TIMEOUT,
        retry=Retry(NoBackoff(), 0),
    )


def redis_key(*parts: object) -> str:
    """A key of this deployment's: the channels prefix keeps two deployments (or test runs)
    sharing one Redis apart."""
    prefix = settings.CHANNEL_LAYERS["default"]["CONFIG"].get("prefix", "hospital_delivery")
    return ":".join([prefix, *map(str, parts)])
