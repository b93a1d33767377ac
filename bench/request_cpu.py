"""CPU time the server spends on one delivery request, measured in-process: steady on a busy
machine.

    python bench/request_cpu.py              # 5 rounds of 100 requests, PostgreSQL
    python bench/request_cpu.py --quick      # 2 rounds of 20: what CI runs
    python bench/request_cpu.py --allocating # each allocated in the request, as a lone one is

bench/latency.py times a burst of requests through the whole stack, and on a shared 2-core
machine it swings with whatever else runs. This one measures the request's own code path, as
bench/heartbeat_cpu.py does the heartbeat's: a staff user's `POST /api/v1/tasks/` (one pick-up,
one drop-off, stations drawn as bench/latency.py draws them) through Django's test client
(middleware, DRF, the token, validation, the task's rows, the answer) against a fresh database
with the Eulji site and 100 robots, and this process's CPU time divided by the requests. The
requests are not allocated in the request (ALLOCATE_ON_REQUEST off): in a burst all but the
first find the site's allocation running and leave it to the worker's batch, whose cost is the
allocator's (bench/allocation.py). With --allocating, the one robot at its dock takes each
request in the request itself (ALLOCATE_ON_REQUEST on, as a request alone on its site is: the
1-user row of bench/latency.py), and between requests it heartbeats in the same process to take
its plan and report the task done, which is not counted. What it leaves out is the HTTP server
(gunicorn) and the database server's work; the queries one request sends are printed.
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

from bench import saving
from bench.stack import database_option, queue_forget, temporary_database

WARMUP = 30  # requests before measuring: caches (site map, statements, serializers) filled


@saving.saves("request_cpu")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds of 20: for CI")
    parser.add_argument(
        "--allocating", action="store_true", help="one robot, each request allocated in it"
    )
    database_option(parser)
    saving.add_argument(parser)
    options = parser.parse_args()
    rounds, per_round = (2, 20) if options.quick else (5, 100)
    with temporary_database(options.database) as url:
        samples, queries = measure(
            url, rounds=rounds, per_round=per_round, allocating=options.allocating
        )
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"delivery request CPU benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{rounds} rounds of {per_round} requests (after {WARMUP} to warm up)")
    if options.allocating:
        print("each allocated in the request to the one robot, which reports it done between")
    print("CPU ms per request: " + " ".join(f"{sample:.3f}" for sample in samples))
    print(f"median {statistics.median(samples):.3f} ms")
    print(f"queries per request: {queries}")


def measure(
    database_url: str, *, rounds: int, per_round: int, allocating: bool = False
) -> tuple[list[float], int]:
    """Per round, this process's CPU ms per request; and the queries of one request."""
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        ALLOWED_HOSTS="localhost",
        ALLOCATE_ON_REQUEST="true" if allocating else "false",
        LOG_LEVEL="WARNING",
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()
    from django.conf import settings
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    from bench.inprocess import SERVER_URL, InProcessTaskApi, InProcessTransport
    from bench.latency import BenchRobot, _prepare, _request
    from core import outbox
    from hospital_delivery.celery import app

    # Unallocated requests ask the worker to allocate them (on commit, from the outbox thread,
    # whose CPU counts as a web worker's would; one message per site on its way,
    # scheduling/pending.py): to a queue of this run's, forgotten at the end.
    app.conf.task_default_queue = f"hd-request-cpu-{uuid.uuid4().hex[:10]}"
    tokens, fleet = _prepare(users=1, robots=1 if allocating else 100)
    api, rng = InProcessTaskApi(tokens[0]), random.Random(1)
    if allocating:  # online at its dock
        robot = BenchRobot(SERVER_URL, *fleet[0], transport=InProcessTransport())
        robot.client.heartbeat()

    def send(count: int) -> float:
        """The CPU ms of `count` requests (not of the robot's heartbeats between them)."""
        spent = 0.0
        for _ in range(count):
            started = time.process_time()
            status, body = api.post(_request(rng))
            spent += time.process_time() - started
            if status != 201:
                raise SystemExit(f"request refused: {status} {body}")
            while allocating and (body["code"] not in robot.received or robot.client.unsent):
                robot.client.heartbeat()  # its plan; then the task's events and the acks
        return spent * 1000

    send(WARMUP)
    samples = [send(per_round) / per_round for _ in range(rounds)]
    with CaptureQueriesContext(connection) as queries:  # one request's, without the robot's
        api.post(_request(rng))
    outbox.drain(timeout=10)
    queue_forget(settings.REDIS_URL, app.conf.task_default_queue)
    return samples, len(queries.captured_queries)


if __name__ == "__main__":
    main()
