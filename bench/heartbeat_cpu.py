"""CPU time the server spends on one heartbeat, measured in-process: steady on a busy machine.

    python bench/heartbeat_cpu.py            # 5 rounds of 1000 heartbeats, PostgreSQL
    python bench/heartbeat_cpu.py --quick    # 2 rounds of 100: what CI runs
    python bench/heartbeat_cpu.py --database sqlite:///
    python bench/heartbeat_cpu.py --floor    # and the floor and bare endpoints, PostgreSQL

bench/heartbeat.py measures what a whole server sustains, and on a shared 2-core machine its
saturated rows swing with whatever else runs. This one measures the cost of the heartbeat's own
code path: a robot at its dock heartbeats (no events, acks or requests) through Django's test
client (middleware, DRF, authentication with the row lock, the board service, the hooks,
the response) against a fresh database, and the process's CPU time (not wall time, so waiting
on the database and other processes' load count for little) is divided by the heartbeats. What
it leaves out is the HTTP server (gunicorn). The database server's own work is printed apart:
the CPU time of the PostgreSQL backend serving this process (read from /proc, so only when the
server runs on this machine), divided by the heartbeats. With --floor, each round also sends
as many of the same heartbeats to the two endpoints bench/heartbeat.py compares the heartbeat
with (bench/urls.py): the floor, the least a heartbeat kept in the database can do, and the
bare endpoint; between the floor's CPU and the heartbeat's lies the heartbeat's own code.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving
from bench.stack import database_option, temporary_database

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"
WARMUP = 200  # heartbeats before measuring: caches (site map, router, statements) filled
HEARTBEAT_PATH = "/api/v1/robots/R1/heartbeat"
# What --floor compares the heartbeat with (bench/urls.py), name: path.
OTHERS = {"floor": "/bench/floor/R1", "bare": "/bench/bare"}


@saving.saves("heartbeat_cpu")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds of 100: for CI")
    parser.add_argument(
        "--floor", action="store_true", help="the floor and bare endpoints too (PostgreSQL)"
    )
    database_option(parser)
    saving.add_argument(parser)
    options = parser.parse_args()
    if options.floor and not options.database.startswith("postgres"):
        parser.error("--floor needs PostgreSQL: the floor's statements are PostgreSQL's")
    rounds, per_round = (2, 100) if options.quick else (5, 1000)
    others = OTHERS if options.floor else {}
    with temporary_database(options.database) as url:
        samples, wal, database, compared = measure(
            url, rounds=rounds, per_round=per_round, others=others
        )
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"heartbeat CPU benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{rounds} rounds of {per_round} heartbeats (after {WARMUP} to warm up)")
    print("CPU ms per heartbeat: " + " ".join(f"{sample:.3f}" for sample in samples))
    print(f"median {statistics.median(samples):.3f} ms")
    for name, other in compared.items():
        print(
            f"CPU ms per {name} request: "
            + " ".join(f"{sample:.3f}" for sample in other)
            + f" (median {statistics.median(other):.3f})"
        )
    if database:
        print(
            "database server CPU ms per heartbeat: "
            + " ".join(f"{sample:.3f}" for sample in database)
            + f" (median {statistics.median(database):.3f})"
        )
    if wal:
        print(
            f"WAL bytes per heartbeat: median {statistics.median(wal):.0f} (the server's whole "
            "write-ahead log: meaningful only when nothing else writes to it)"
        )


def measure(
    database_url: str, *, rounds: int, per_round: int, others: dict[str, str] | None = None
) -> tuple[list[float], list[float], list[float], dict[str, list[float]]]:
    """Per round: this process's CPU ms per heartbeat, WAL bytes per heartbeat and the
    database server's CPU ms per heartbeat (the last two empty where they cannot be read);
    and this process's CPU ms per request of each of `others` (name: path), the same
    heartbeats sent there in the same rounds."""
    others = others or {}
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        ALLOWED_HOSTS="testserver",
        LOG_LEVEL="WARNING",
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()
    from django.conf import settings
    from django.test import Client

    settings.ROOT_URLCONF = "bench.urls"  # the project's URLs, the floor and the bare endpoint

    from robots.models import Robot
    from robots.services import robot_token_issue
    from robots.sitefile import site_file_read, site_load

    site_load(data=site_file_read(SITE_FILE))
    token = robot_token_issue(robot=Robot.objects.get(code="R1"))
    beat = _Heartbeats(Client(), token)
    for path in (HEARTBEAT_PATH, *others.values()):
        beat.send(WARMUP, path)
    samples, wal, database = [], [], []
    compared = {name: [] for name in others}
    backend = _backend_cpu_reader()
    for _ in range(rounds):
        wal_before = _wal_position()
        backend_before = backend() if backend else None
        started = time.process_time()
        beat.send(per_round)
        samples.append((time.process_time() - started) / per_round * 1000)
        if backend_before is not None:
            database.append((backend() - backend_before) / per_round * 1000)
        if wal_before is not None:
            wal.append((_wal_position() - wal_before) / per_round)
        for name, path in others.items():
            started = time.process_time()
            beat.send(per_round, path)
            compared[name].append((time.process_time() - started) / per_round * 1000)
    return samples, wal, database, compared


def _backend_cpu_reader():
    """A function returning the CPU seconds used so far by the PostgreSQL backend serving this
    process's connection; None where it cannot be read (SQLite, a server on another machine,
    a connection not kept between heartbeats)."""
    from django.conf import settings
    from django.db import connection

    if connection.vendor != "postgresql" or not settings.DATABASES["default"]["CONN_MAX_AGE"]:
        return None
    with connection.cursor() as cursor:
        cursor.execute("SELECT pg_backend_pid()")
        stat = Path(f"/proc/{cursor.fetchone()[0]}/stat")
    if not stat.exists():
        return None
    ticks = os.sysconf("SC_CLK_TCK")

    def read() -> float:
        # Fields 14 and 15 (utime, stime), counted after the parenthesised command name.
        fields = stat.read_text().rpartition(")")[2].split()
        return (int(fields[11]) + int(fields[12])) / ticks

    return read


def _wal_position() -> int | None:
    """Where PostgreSQL's write-ahead log is, in bytes (None on SQLite)."""
    from django.db import connection

    if connection.vendor != "postgresql":
        return None
    with connection.cursor() as cursor:
        cursor.execute("SELECT pg_current_wal_lsn() - '0/0'")
        return int(cursor.fetchone()[0])


class _Heartbeats:
    """Robot R1 at its dock, heartbeating with rising seq and checking every answer; to the
    heartbeat's path, or to another endpoint given the same bodies."""

    def __init__(self, client, token: str):
        self.client, self.token, self.seq = client, token, 0

    def send(self, count: int, path: str = HEARTBEAT_PATH) -> None:
        for _ in range(count):
            self.seq += 1
            response = self.client.post(
                path,
                json.dumps(self._body()),
                content_type="application/json",
                headers={"Authorization": f"Bearer {self.token}"},
            )
            if response.status_code != 200:
                raise SystemExit(f"heartbeat {self.seq}: {response.status_code} {response.content}")

    def _body(self) -> dict:
        state = {"status": "idle", "floor": "15F", "waypoint": "15F-DOCK-1", "battery": 0.9}
        state.update(load=0, plan_version=0)
        return {"boot_id": "bench", "seq": self.seq, "state": state, "events": [], "acks": []}


if __name__ == "__main__":
    main()
