"""The watchdog of the periodic sweeps (for /healthz and every page's alert).

Every sweep Celery beat schedules (settings.CELERY_BEAT_SCHEDULE) records when it last ran,
in Redis, as it finishes (`sweep_ran`, a receiver of Celery's task_success connected in
hospital_delivery/extensions.py, so the tasks themselves stay as they are). A sweep that has
not run for SWEEP_OVERDUE_INTERVALS of its intervals is overdue: presence, grant expiry and
acknowledgement timeouts stop being enforced, so every page shows an alert and /healthz
answers 503 naming it.
"""

import logging
import time
from datetime import UTC, datetime

import redis
from django.conf import settings

from core.redisclient import redis_client, redis_key

logger = logging.getLogger(__name__)

SWEEP_OVERDUE_INTERVALS = 5
SWEEP_OVERDUE_MIN_SECONDS = 15  # beat and a busy worker may lag a few seconds


def _sweeps() -> dict[str, float]:
    """Task name -> its interval in seconds, for every sweep beat runs."""
    return {
        entry["task"]: float(entry["schedule"]) for entry in settings.CELERY_BEAT_SCHEDULE.values()
    }


def _key(task_name: str) -> str:
    return redis_key("sweep-ran", task_name)


def sweep_ran(sender=None, **kwargs) -> None:
    """A task finished: if it is a sweep, record when."""
    name = getattr(sender, "name", None)
    if name in _sweeps():
        sweep_record(name)


def sweep_record(task_name: str, at: float | None = None) -> None:
    try:
        redis_client().set(_key(task_name), at if at is not None else time.time())
    except redis.RedisError:
        logger.warning("could not record that %s ran", task_name)


def sweeps_last_runs() -> dict[str, float | None]:
    """Each sweep's last run (Unix time, or None if never), by task name; raises RedisError."""
    names = sorted(_sweeps())
    runs = redis_client().mget([_key(name) for name in names])
    return {
        name: None if raw is None else float(raw) for name, raw in zip(names, runs, strict=True)
    }


def sweeps_status(now: float | None = None) -> dict[str, dict]:
    """Each sweep's last run (ISO time or None) and whether it is on time; raises RedisError."""
    now = now if now is not None else time.time()
    sweeps = _sweeps()
    status = {}
    for name, last in sweeps_last_runs().items():
        allowed = max(SWEEP_OVERDUE_INTERVALS * sweeps[name], SWEEP_OVERDUE_MIN_SECONDS)
        status[name] = {
            "last_run": datetime.fromtimestamp(last, UTC).isoformat() if last else None,
            "ok": last is not None and now - last <= allowed,
        }
    return status


def sweeps_overdue() -> list[str]:
    """The sweeps not run lately (for the pages' alert); every sweep if Redis is unreachable."""
    try:
        status = sweeps_status()
    except redis.RedisError:
        return sorted(_sweeps())
    return [name for name, sweep in status.items() if not sweep["ok"]]
