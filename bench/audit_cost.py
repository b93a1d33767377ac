"""What an audit entry adds to a nurse's order and to an operator's action, measured in-process
in one run, with and without the entry.

    python bench/audit_cost.py           # 7 rounds of 40 of each, PostgreSQL
    python bench/audit_cost.py --quick   # 2 rounds of 10: what CI runs

An order is a staff user's `POST /api/v1/tasks/` (as bench/request_cpu.py sends it: one pick-up,
one drop-off, not allocated in the request); an operator action is the robot page's Pause or
Resume (`POST /robots/<code>/action`, alternating), both through Django's test client (the whole
middleware, the session or token, the view, the service) against a fresh database with the
Eulji site and 100 robots. Rounds with and without the entry alternate, so both meet the same
machine; "without" replaces the call that writes the entry (`entry_record` where the order's
and the action's services call it) by one that writes nothing. Times are wall-clock, since what
an entry costs is mostly its three statements at the database (the chain head locked, the
entry inserted, the head moved on); the queries of one request are counted both ways.
"""

from __future__ import annotations

import argparse
import contextlib
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

WARMUP = 20  # of each, before measuring: caches (site map, statements, content types) filled


@saving.saves("audit_cost")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds of 10: for CI")
    database_option(parser)
    saving.add_argument(parser)
    options = parser.parse_args()
    rounds, per_round = (2, 10) if options.quick else (7, 40)
    with temporary_database(options.database) as url:
        results = measure(url, rounds=rounds, per_round=per_round)
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"audit entry cost benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{rounds} rounds of {per_round} of each, with and without the entry, alternating")
    print("| request | median ms without | median ms with | added | queries without | with |")
    print("|---|---|---|---|---|---|")
    for name, (without, with_entry, queries) in results.items():
        low, high = statistics.median(without), statistics.median(with_entry)
        print(
            f"| {name} | {low:.2f} | {high:.2f} | {high - low:+.2f} | {queries[0]} | {queries[1]} |"
        )


def measure(database_url: str, *, rounds: int, per_round: int) -> dict:
    """Per kind of request: the per-round median ms without and with the entry, and the
    queries of one request without and with."""
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
    from django.contrib.auth import get_user_model

    from bench.inprocess import InProcessTaskApi, test_client
    from bench.latency import _prepare, _request
    from core import outbox
    from hospital_delivery.celery import app

    app.conf.task_default_queue = f"hd-audit-cost-{uuid.uuid4().hex[:10]}"
    tokens, fleet = _prepare(users=1, robots=100)
    api, rng = InProcessTaskApi(tokens[0]), random.Random(1)
    operator = test_client()
    operator.force_login(get_user_model().objects.get(username="nurse000"))  # staff
    robot_code = fleet[0][0]

    def order() -> None:
        status, body = api.post(_request(rng))
        if status != 201:
            raise SystemExit(f"order refused: {status} {body}")

    def pause_or_resume(flip=[False]) -> None:  # noqa: B006 (alternates across calls)
        flip[0] = not flip[0]
        action = "pause" if flip[0] else "resume"
        response = operator.post(f"/robots/{robot_code}/action", {"action": action})
        if response.status_code != 302:
            raise SystemExit(f"action refused: {response.status_code}")

    kinds = {
        "nurse's order (POST /api/v1/tasks/)": (order, "scheduling.services.requests"),
        "operator's pause or resume (robot page)": (
            pause_or_resume,
            "scheduling.services.operator",
        ),
    }
    results = {}
    for name, (send, module) in kinds.items():
        results[name] = _compare(send, module, rounds=rounds, per_round=per_round)
    outbox.drain(timeout=10)
    queue_forget(settings.REDIS_URL, app.conf.task_default_queue)
    return results


def _compare(send, module: str, *, rounds: int, per_round: int):
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    def timed() -> float:
        samples = []
        for _ in range(per_round):
            started = time.perf_counter()
            send()
            samples.append((time.perf_counter() - started) * 1000)
        return statistics.median(samples)

    def counted() -> float:
        """Queries per request over two (an operator's pause, then resume, differ)."""
        with CaptureQueriesContext(connection) as queries:
            send()
            send()
        return len(queries.captured_queries) / 2

    for _ in range(WARMUP):
        send()
    without, with_entry = [], []
    for _ in range(rounds):
        with _no_entry(module):
            without.append(timed())
        with_entry.append(timed())
    with _no_entry(module):
        queries_without = counted()
    return without, with_entry, (queries_without, counted())


@contextlib.contextmanager
def _no_entry(module: str):
    """The service module's entry_record, replaced by one that writes nothing."""
    import importlib

    target = importlib.import_module(module)
    original = target.entry_record
    target.entry_record = lambda **kwargs: None
    try:
        yield
    finally:
        target.entry_record = original


if __name__ == "__main__":
    main()
