"""GET /healthz for load balancers and monitoring: the database, Redis and each sweep's last
run (core/watchdog.py); 503 naming what is down. No login, and nothing secret in the answer.
"""

import logging

import redis
from django.db import connection
from django.http import JsonResponse
from django.views.decorators.cache import never_cache
from django.views.decorators.http import require_GET

from core.watchdog import sweeps_status

logger = logging.getLogger(__name__)


def _database_ok() -> bool:
    try:
        with connection.cursor() as cursor:
            cursor.execute("SELECT 1")
        return True
    except Exception:
        logger.exception("health check: database unreachable")
        return False


@never_cache
@require_GET
def healthz(request):
    database = _database_ok()
    try:
        sweeps, redis_ok = sweeps_status(), True
    except redis.RedisError:
        sweeps, redis_ok = {}, False
    sweeps_ok = redis_ok and all(sweep["ok"] for sweep in sweeps.values())
    down = [
        part
        for part, ok in (("database", database), ("redis", redis_ok), ("sweeps", sweeps_ok))
        if not ok
    ]
    body = {
        "status": "down" if down else "ok",
        "down": down,
        "database": "ok" if database else "down",
        "redis": "ok" if redis_ok else "down",
        "sweeps": sweeps,
    }
    return JsonResponse(body, status=503 if down else 200)
