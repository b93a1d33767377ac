"""Reads behind the operations metrics (reports/metrics.py), computed at scrape time from the
database and Redis, so every gunicorn worker answers the same and nothing is kept in memory.

Each is one aggregate query over an indexed or small set of rows (robots, live leases,
pending board messages, open tasks), a few milliseconds at a scrape every 15 s.
"""

import functools
import logging
from dataclasses import dataclass
from datetime import datetime

import redis
from celery import current_app
from django.conf import settings
from django.db.models import Count, Min

from boards.models import BoardMessage
from core.watchdog import sweeps_last_runs
from resources.choices import LeaseState
from resources.models import Lease
from robots.choices import Presence
from robots.models import Resource, Robot
from scheduling.choices import FINISHED_STATUSES, TaskStatus
from scheduling.models import Task

logger = logging.getLogger(__name__)

# Not yet at their destination: a delivery still in one of these is late once its due time passes.
UNDELIVERED = [s for s in TaskStatus.values if s not in {*FINISHED_STATUSES, TaskStatus.DELIVERED}]


def robots_by_state() -> list[dict]:
    """[{"site", "presence", "status", "n"}]: how many robots in each presence and status."""
    rows = Robot.objects.values("site__code", "presence", "status").annotate(n=Count("pk"))
    return [_site(row) for row in rows.order_by()]


def robots_load() -> list[dict]:
    """[{"site", "code", "presence", "load"}]: items each robot carries, and its presence."""
    rows = Robot.objects.values("site__code", "code", "presence", "load").order_by("code")
    return [_site(row) for row in rows]


def tasks_by_status() -> list[dict]:
    rows = Task.objects.values("site__code", "status").annotate(n=Count("pk"))
    return [_site(row) for row in rows.order_by()]


def tasks_past_due(now: datetime) -> list[dict]:
    """[{"site", "priority", "n"}]: deliveries not yet delivered whose own due time (`due_at`)
    has passed; tasks from before deadlines existed have none and are never past due."""
    late = Task.objects.filter(due_at__lt=now, status__in=UNDELIVERED)
    rows = late.values("site__code", "priority").annotate(n=Count("pk"))
    return [_site(row) for row in rows.order_by()]


def lease_queues(now: datetime) -> list[dict]:
    """[{"site", "resource", "kind", "queued", "oldest_wait"}] for every resource."""
    queued = {
        row["resource"]: row
        for row in Lease.objects.filter(state=LeaseState.QUEUED)
        .values("resource")
        .annotate(n=Count("pk"), oldest=Min("requested_at"))
        .order_by()
    }
    rows = []
    for resource in Resource.objects.values("pk", "site__code", "code", "kind").order_by("pk"):
        waiting = queued.get(resource["pk"])
        oldest = (now - waiting["oldest"]).total_seconds() if waiting else 0.0
        rows.append(
            {
                "site": resource["site__code"],
                "resource": resource["code"],
                "kind": resource["kind"],
                "queued": waiting["n"] if waiting else 0,
                "oldest_wait": max(oldest, 0.0),
            }
        )
    return rows


def board_pending(now: datetime) -> list[dict]:
    """[{"site", "pending", "oldest_age"}]: messages on boards not acked (nor withdrawn)."""
    rows = (
        BoardMessage.objects.pending()
        .values("robot__site__code")
        .annotate(n=Count("pk"), oldest=Min("posted_at"))
        .order_by()
    )
    return [
        {
            "site": row["robot__site__code"],
            "pending": row["n"],
            "oldest_age": max((now - row["oldest"]).total_seconds(), 0.0),
        }
        for row in rows
    ]


def sweep_lags(now: datetime) -> dict[str, float]:
    """Per sweep, how long ago the oldest deadline it has not yet acted on passed (0: none).

    A sweep that keeps up leaves nothing past its deadline for more than its period.
    """
    robots = Robot.objects.order_by()
    deadlines = {
        "presence": [
            robots.filter(presence=Presence.ONLINE, unreachable_at__lte=now).aggregate(
                at=Min("unreachable_at")
            )["at"],
            robots.filter(
                presence__in=[Presence.ONLINE, Presence.UNREACHABLE], offline_at__lte=now
            ).aggregate(at=Min("offline_at"))["at"],
        ],
        "due": [_oldest(Task, "requested_time", status=TaskStatus.SCHEDULED, now=now)],
        "ack_timeout": [_oldest(Task, "ack_due_at", status=TaskStatus.ASSIGNED, now=now)],
        "lease_expiry": [_oldest(Lease, "expires_at", state=LeaseState.GRANTED, now=now)],
    }
    return {
        sweep: max([(now - at).total_seconds() for at in ats if at is not None], default=0.0)
        for sweep, ats in deadlines.items()
    }


def _oldest(model, field: str, *, now: datetime, **where):
    rows = model.objects.filter(**where, **{f"{field}__lte": now}).order_by()
    return rows.aggregate(at=Min(field))["at"]


# --- Redis: Celery's queue and when each sweep last ran -----------------------------------------


def celery_queue() -> str:
    return current_app.conf.task_default_queue


@functools.cache
def _redis() -> redis.Redis:
    # redis-py's pool notices a fork and opens new connections in the child.
    return redis.Redis.from_url(settings.REDIS_URL, socket_timeout=2, socket_connect_timeout=2)


@dataclass(frozen=True)
class BrokerState:
    queue_length: int
    sweeps_last_run: dict[str, float]  # Celery task name -> Unix time of its last success


def broker_state() -> BrokerState | None:
    """Celery's queue length and the sweeps' last runs (as the sweeps' watchdog records them,
    core/watchdog.py), or None if Redis does not answer."""
    try:
        length = _redis().llen(celery_queue())
        runs = sweeps_last_runs()
    except redis.RedisError:
        logger.warning("Redis did not answer the metrics scrape", exc_info=True)
        return None
    return BrokerState(length, {name: at for name, at in runs.items() if at is not None})


def _site(row: dict) -> dict:
    row["site"] = row.pop("site__code")
    return row
