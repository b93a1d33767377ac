"""At most one allocation message on its way per site (and Celery queue).

Every request the site's allocation lock turns away, every task handed back by a robot gone
offline or by an acknowledgement timeout, asks the Celery worker to allocate its site's due
tasks (site_allocate_due). One message per task made a burst of 100 requests 100 messages:
the first few ran batches, the rest each took the worker 15-30 ms (Celery's own work, the
lock, reading no due task) while the robots the batches had woken waited for the cores
(bench/latency.py). A batch reads every task then due, so one message waiting per site is
enough: the sender claims the site's key and sends only if it was free; the worker frees the
key as it takes the message, before it waits for the lock and reads the due tasks, so a task
committed after that read finds the key free and sends a message of its own.

The key expires after PENDING_SECONDS: a message lost after its claim holds the others back
for that long at most, and the due sweep (every SWEEP_SECONDS) allocates meanwhile.
"""

import logging

import redis

from core.redisclient import redis_client, redis_key

logger = logging.getLogger(__name__)

PENDING_SECONDS = 5


def allocation_pending_claim(site_id: int, queue: str) -> str | None:
    """The site's key, now claimed, if no allocation message is on its way to `queue`; else
    None. Raises RedisError (so does the message's own send)."""
    key = redis_key("allocation-pending", queue, site_id)
    return key if redis_client().set(key, 1, nx=True, ex=PENDING_SECONDS) else None


def allocation_pending_free(key: str) -> None:
    """The worker took the message: the next task made due sends one again."""
    try:
        redis_client().delete(key)
    except redis.RedisError:
        logger.warning("could not free %s: it expires in %d s", key, PENDING_SECONDS)
