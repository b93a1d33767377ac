"""CPU time the server spends on one delivery request, measured in-process: steady on a busy
machine.

    python bench/request_cpu.py            # 5 rounds of 100 requests, PostgreSQL
    python bench/request_cpu.py --quick    # 2 rounds of 20: what CI runs

bench/latency.py times a burst of requests through the whole stack, and on a shared 2-core
machine it swings with whatever else runs. This one measures the request's own code path, as
bench/heartbeat_cpu.py does the heartbeat's: a staff user's `POST /api/v1/tasks/` (one pick-up,
one drop-off, stations drawn as bench/latency.py draws them) through Django's test client
(middleware, DRF, the token, validation, the task's rows, the answer) against a fresh database
with the Eulji site and 100 robots, and this process's CPU time divided by the requests. The
requests are not allocated in the request (ALLOCATE_ON_REQUEST off): in a burst all but the
first find the site's allocation running and leave it to the worker's batch, whose cost is the
allocator's (bench/allocation.py). What it leaves out is the HTTP server (gunicorn) and the
database server's work; the queries one request sends are printed.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import random
import statistics
import sys
import time
import uuid
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.stack import database_option, queue_forget, temporary_database

WARMUP = 30  # requests before measuring: caches (site map, statements, serializers) filled


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds of 20: for CI")
    database_option(parser)
    options = parser.parse_args()
    rounds, per_round = (2, 20) if options.quick else (5, 100)
    with temporary_database(options.database) as url:
        samples, queries = measure(url, rounds=rounds, per_round=per_round)
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"delivery request CPU benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{rounds} rounds of {per_round} requests (after {WARMUP} to warm up)")
    print("CPU ms per request: " + " ".join(f"{sample:.3f}" for sample in samples))
    print(f"median {statistics.median(samples):.3f} ms")
    print(f"queries per request: {queries}")


def measure(database_url: str, *, rounds: int, per_round: int) -> tuple[list[float], int]:
    """Per round, this process's CPU ms per request; and the queries of one request."""
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        ALLOWED_HOSTS="localhost",
        ALLOCATE_ON_REQUEST="false",
        LOG_LEVEL="WARNING",
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()
    from django.conf import settings
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    from bench.inprocess import InProcessTaskApi
    from bench.latency import _prepare, _request
    from core import outbox
    from hospital_delivery.celery import app

    # Each request asks the worker to allocate it (on commit, from the outbox thread, whose
    # CPU counts as a web worker's would): to a queue of this run's, forgotten at the end.
    app.conf.task_default_queue = f"hd-request-cpu-{uuid.uuid4().hex[:10]}"
    tokens, _robots = _prepare(users=1, robots=100)
    api, rng = InProcessTaskApi(tokens[0]), random.Random(1)

    def send(count: int) -> None:
        for _ in range(count):
            status, body = api.post(_request(rng))
            if status != 201:
                raise SystemExit(f"request refused: {status} {body}")

    send(WARMUP)
    samples = []
    for _ in range(rounds):
        started = time.process_time()
        send(per_round)
        samples.append((time.process_time() - started) / per_round * 1000)
    with CaptureQueriesContext(connection) as queries:
        send(1)
    outbox.drain(timeout=10)
    queue_forget(settings.REDIS_URL, app.conf.task_default_queue)
    return samples, len(queries.captured_queries)


if __name__ == "__main__":
    main()
