"""Instructions the server executes for one heartbeat: a count that does not move with the load.

    python bench/heartbeat_instructions.py            # 200 heartbeats counted, PostgreSQL
    python bench/heartbeat_instructions.py --quick    # 20: what CI runs
    python bench/heartbeat_instructions.py --database sqlite:///

bench/heartbeat_cpu.py divides CPU time by heartbeats, and on a shared machine that time moves
by a third between runs of the same code (1.6 to 2.7 ms a heartbeat by process time, in rounds
of this script's loop, 2026-11-24). This counts instructions
instead, with valgrind's callgrind (Debian's package `valgrind`), which counts the same for the
same code and input whatever else the machine runs: a change of 1 % shows. A robot at its dock
heartbeats (no events, acks or requests; the body of bench/heartbeat.py) through Django's WSGI
handler as gunicorn calls it (every middleware, DRF, the row lock, the board, the answer), not
through the test client, so nothing of the test client is counted. The process runs twice under
callgrind, side by side (robots R1 and R2), sending 20 heartbeats and 20 + N; the difference
of the two totals, divided by N, leaves out the start (imports, the site loaded, the caches
filled). The HTTP server and the database server are not counted; the queries a heartbeat
sends are printed, for those.
"""

from __future__ import annotations

import argparse
import datetime
import io
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.heartbeat import heartbeat_body
from bench.stack import database_option, temporary_database

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"
WARMUP = 20  # heartbeats in both runs: caches (site map, statements, prepared queries) filled


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 heartbeats counted: for CI")
    parser.add_argument("--send", type=int, help=argparse.SUPPRESS)  # the child under valgrind
    parser.add_argument("--robot", default="R1", help=argparse.SUPPRESS)
    database_option(parser)
    options = parser.parse_args()
    if options.send is not None:
        _heartbeats_send(options.database, options.send, options.robot)
        return
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        raise SystemExit("valgrind is needed: apt-get install valgrind (Debian's package)")
    counted = 20 if options.quick else 200
    with temporary_database(options.database) as url:
        queries = _queries_of_one(url)
        before, after = _instructions(valgrind, url, (WARMUP, WARMUP + counted))
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"heartbeat instructions benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{counted} heartbeats counted (after {WARMUP}), through the WSGI handler")
    print(f"instructions per heartbeat: {(after - before) / counted:,.0f}")
    print(f"queries per heartbeat: {len(queries)} ({', '.join(queries)})")


def _instructions(valgrind: str, database_url: str, counts: tuple[int, ...]) -> list[int]:
    """The instructions a process sending each count of heartbeats executes in all, by
    callgrind; the processes run side by side."""
    with tempfile.TemporaryDirectory(prefix="hd-callgrind-") as directory:
        runs = [
            subprocess.Popen(
                [
                    *(valgrind, "--tool=callgrind", f"--callgrind-out-file={directory}/{count}"),
                    *(sys.executable, __file__, "--send", str(count)),
                    *("--robot", f"R{n}", "--database", database_url),
                ],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            for n, count in enumerate(counts, 1)
        ]
        outputs = [run.communicate() for run in runs]
    totals = []
    for run, (stdout, stderr) in zip(runs, outputs, strict=True):
        collected = re.search(r"Collected : (\d+)", stderr)
        if run.returncode != 0 or collected is None:
            raise SystemExit(f"a counted run failed:\n{stdout}\n{stderr}")
        totals.append(int(collected.group(1)))
    return totals


def _queries_of_one(database_url: str) -> list[str]:
    """The verb and table of each statement one heartbeat sends (in a child process)."""
    finished = subprocess.run(
        [sys.executable, __file__, "--send", "-1", "--database", database_url],
        capture_output=True,
        text=True,
        check=False,
    )
    if finished.returncode != 0:
        raise SystemExit(f"the heartbeat whose queries are listed failed:\n{finished.stderr}")
    return finished.stdout.split("\n")[-2].split("|")


def _heartbeats_send(database_url: str, count: int, robot: str = "R1") -> None:
    """Set up Django on the database, then send `count` heartbeats; with -1, one heartbeat
    after a warm-up, printing its statements' verbs and tables."""
    send = _sender(database_url, robot)
    if count >= 0:
        for _ in range(count):
            send()
        return
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    for _ in range(WARMUP):
        send()
    with CaptureQueriesContext(connection) as captured:
        send()
    print("|".join(_statement_name(query["sql"]) for query in captured.captured_queries))


def _statement_name(sql: str) -> str:
    """`SELECT robots_robot`, `UPDATE robots_robot`, `COMMIT`: the verb and its table."""
    table = re.search(r'(?:FROM|UPDATE|INTO) "(\w+)"', sql)
    return f"{sql.split()[0]} {table.group(1)}" if table else " ".join(sql.split()[:2])


def _sender(database_url: str, robot: str):
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        ALLOWED_HOSTS="127.0.0.1",
        LOG_LEVEL="WARNING",
        DATABASE_CONN_MAX_AGE="600",  # one connection, as a gunicorn worker keeps
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()
    from django.core.wsgi import get_wsgi_application

    from robots.models import Robot
    from robots.services import robot_token_issue
    from robots.sitefile import site_file_read, site_load

    site_load(data=site_file_read(SITE_FILE))
    token = robot_token_issue(robot=Robot.objects.get(code=robot))
    application = get_wsgi_application()
    seq = iter(range(1, 2**62))

    def send() -> None:
        body = heartbeat_body("bench", next(seq), robot)
        statuses: list[str] = []
        environ = _environ(body, robot, token)
        answer = b"".join(application(environ, lambda s, h, e=None: statuses.append(s)))
        if not statuses[0].startswith("200"):
            raise SystemExit(f"heartbeat: {statuses[0]} {answer[:500]!r}")

    return send


def _environ(body: bytes, robot: str, token: str) -> dict:
    """What gunicorn hands the application for the robot's POST."""
    return {
        "REQUEST_METHOD": "POST",
        "PATH_INFO": f"/api/v1/robots/{robot}/heartbeat",
        "SCRIPT_NAME": "",
        "QUERY_STRING": "",
        "SERVER_NAME": "127.0.0.1",
        "SERVER_PORT": "8000",
        "SERVER_PROTOCOL": "HTTP/1.1",
        "REMOTE_ADDR": "127.0.0.1",
        "HTTP_HOST": "127.0.0.1",
        "CONTENT_TYPE": "application/json",
        "CONTENT_LENGTH": str(len(body)),
        "HTTP_AUTHORIZATION": f"Bearer {token}",
        "wsgi.input": io.BytesIO(body),
        "wsgi.errors": sys.stderr,
        "wsgi.url_scheme": "http",
        "wsgi.version": (1, 0),
        "wsgi.multithread": False,
        "wsgi.multiprocess": True,
        "wsgi.run_once": False,
    }


if __name__ == "__main__":
    main()
