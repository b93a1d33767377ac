"""Redis for the server's courtesies (the sweeps' last runs, the allocation messages waiting per
site, the publishes of core/pubsub.py): one client per process and address, with short timeouts
and no retries, since a sweep, a timeout or the next heartbeat makes up for whatever one of
them fails to do when Redis stalls."""

import functools

import redis
from django.conf import settings
from redis.backoff import NoBackoff
from redis.retry import Retry

TIMEOUT = 0.5  # seconds to connect, and to send a command and read its answer


@functools.cache
def redis_client(url: str | None = None) -> redis.Redis:
    """The client of `url`, by default settings.REDIS_URL."""
    # redis-py's pool notices a fork and opens new connections in the child.
    return redis.Redis.from_url(
        url or settings.REDIS_URL,
        socket_timeout=TIMEOUT,
        socket_connect_timeout=TIMEOUT,
        retry=Retry(NoBackoff(), 0),
    )


def redis_key(*parts: object) -> str:
    """A key of this deployment's: the channels prefix keeps two deployments (or test runs)
    sharing one Redis apart."""
    prefix = settings.CHANNEL_LAYERS["default"]["CONFIG"].get("prefix", "hospital_delivery")
    return ":".join([prefix, *map(str, parts)])
