"""Instructions the server executes for one heartbeat: a count that does not move with the load.

    python bench/heartbeat_instructions.py            # 200 heartbeats counted, PostgreSQL
    python bench/heartbeat_instructions.py --quick    # 20: what CI runs
    python bench/heartbeat_instructions.py --database sqlite:///
    python bench/heartbeat_instructions.py --delivery # 30 delivery cycles counted (--quick: 3)

bench/heartbeat_cpu.py divides CPU time by heartbeats, and on a shared machine that time moves
by as much as a third between runs of the same code. This counts instructions
instead, with valgrind's callgrind (Debian's package `valgrind`), which counts the same for the
same code and input whatever else the machine runs: a change of 1 % shows. A robot at its dock
heartbeats (no events, acks or requests; the body of bench/heartbeat.py) through Django's WSGI
handler as gunicorn calls it (every middleware, DRF, the row lock, the board, the answer), not
through the test client, so nothing of the test client is counted. The process runs once under
callgrind with its instrumentation off (`--instr-atstart=no`: the start, imports, the site loaded
and 20 heartbeats that fill the caches run several times faster uninstrumented), then turns it
on and off around two windows (callgrind_control, each window dumped): one with no heartbeat,
one with N; the difference of the two, divided by N, leaves out what the switching itself costs.
The HTTP server and the database server are not counted; the queries a heartbeat
sends are printed, for those, and on PostgreSQL its round trips (libpq's trace,
core/pgtrace.py: what a web worker waits for), from another process on a database of its own.

With --delivery it counts a delivery's cycle instead, what a burst of requests costs the web
workers per task (bench/latency.py): a staff user's `POST /api/v1/tasks/` allocated in the
request to the one robot at its dock (ALLOCATE_ON_REQUEST), the robot's heartbeat that takes
the plan, the one that reports the delivery done (loaded, unloaded, task_completed, as
bench/latency.py's robots report at once) and the one that acknowledges.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import io
import json
import os
import platform
import random
import re
import shutil
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path
from urllib.parse import urlsplit

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving
from bench.heartbeat import heartbeat_body
from bench.stack import database_option, temporary_database

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"
WARMUP = 20  # heartbeats before counting: caches (site map, statements, prepared queries) filled
CYCLES_WARMUP = 5  # delivery cycles likewise (--delivery)


@saving.saves("heartbeat_instructions")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 heartbeats counted: for CI")
    parser.add_argument(
        "--delivery", action="store_true", help="count delivery cycles, not plain heartbeats"
    )
    parser.add_argument("--send", type=int, help=argparse.SUPPRESS)  # the child under valgrind
    database_option(parser)
    saving.add_argument(parser)
    options = parser.parse_args()
    if options.send is not None and options.delivery:
        _child(_cycler(options.database), options.send, CYCLES_WARMUP)
        _django_finish()
        return
    if options.send is not None:
        _child(_sender(options.database, "R1"), options.send, WARMUP)
        return
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        raise SystemExit("valgrind is needed: apt-get install valgrind (Debian's package)")
    if options.delivery:
        _delivery_main(valgrind, options)
        return
    counted = 20 if options.quick else 200
    with contextlib.ExitStack() as stack:
        # Each process loads its site and robot: a database each.
        urls = [stack.enter_context(temporary_database(options.database)) for _ in range(2)]
        before, after, queries, trips = _instructions(valgrind, urls, counted)
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"heartbeat instructions benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{counted} heartbeats counted (after {WARMUP}), through the WSGI handler")
    print(f"instructions per heartbeat: {(after - before) / counted:,.0f}")
    print(f"queries per heartbeat: {len(queries)} ({', '.join(queries)})")
    if trips:
        print(f"round trips to PostgreSQL per heartbeat: {len(trips)} ({', '.join(trips)})")


def _delivery_main(valgrind: str, options) -> None:
    counted = 3 if options.quick else 30
    with contextlib.ExitStack() as stack:
        # Each process makes its site, robot and user: a database each.
        urls = [stack.enter_context(temporary_database(options.database)) for _ in range(2)]
        before, after, queries, trips = _instructions(valgrind, urls, counted, ["--delivery"])
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"delivery instructions benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{counted} delivery cycles counted (after {CYCLES_WARMUP}), through the WSGI handler")
    print(f"instructions per delivery cycle: {(after - before) / counted:,.0f}")
    print(f"queries per delivery cycle: {len(queries)} (a request, three heartbeats)")
    if trips:
        print(f"round trips to PostgreSQL per delivery cycle: {len(trips)}")


def _instructions(
    valgrind: str, database_urls: list[str], counted: int, extra=()
) -> tuple[int, int, list[str], list[str]]:
    """The instructions of callgrind's two windows (no heartbeat, then `counted` heartbeats, or
    delivery cycles with extra ["--delivery"]) in a process on the first database; and the
    statements of one (_queries_of_one) from a process on the second, run meanwhile."""
    with tempfile.TemporaryDirectory(prefix="hd-callgrind-") as directory:
        out = f"{directory}/callgrind.out"
        run = subprocess.Popen(
            [
                *(
                    valgrind,
                    "--tool=callgrind",
                    "--instr-atstart=no",
                    f"--callgrind-out-file={out}",
                ),
                *(sys.executable, __file__, "--send", str(counted), *extra),
                *("--database", database_urls[0]),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        queries, trips = _queries_of_one(database_urls[1], extra)
        stdout, stderr = run.communicate()
        windows = [Path(f"{out}.{n}") for n in (1, 2)]
        if run.returncode != 0 or not all(window.exists() for window in windows):
            raise SystemExit(f"the counted run failed:\n{stdout}\n{stderr}")
        before, after = (_totals(window.read_text()) for window in windows)
    return before, after, queries, trips


def _totals(dump: str) -> int:
    """The instructions a callgrind dump counted (its `totals:` line)."""
    return int(re.search(r"^totals: (\d+)", dump, re.MULTILINE).group(1))


def _callgrind(option: str) -> None:
    """Tell the callgrind running this process `option` (`--instr=on`, `--dump`)."""
    subprocess.run(["callgrind_control", option, str(os.getpid())], capture_output=True, check=True)


def _queries_of_one(database_url: str, extra=()) -> tuple[list[str], list[str]]:
    """The verb and table of each statement one heartbeat (or delivery cycle, extra
    ["--delivery"]) sends, as Django's query log lists them (its BEGIN and COMMIT included,
    sent or not); and, on PostgreSQL, the round trips of another (core/pgtrace.py); in a
    child process."""
    finished = subprocess.run(
        [sys.executable, __file__, "--send", "-1", *extra, "--database", database_url],
        capture_output=True,
        text=True,
        check=False,
    )
    if finished.returncode != 0:
        raise SystemExit(f"the run whose queries are listed failed:\n{finished.stderr}")
    queries, trips = finished.stdout.split("\n")[-3:-1]
    return queries.split("|"), trips.split("|") if trips else []


def _cycler(database_url: str):
    """One staff user and the robot R1 at its dock on the Eulji site; a function that runs one
    delivery cycle (the request, then the robot's three heartbeats) through the WSGI handler."""
    _django_setup(database_url, ALLOCATE_ON_REQUEST="true")
    from django.core.wsgi import get_wsgi_application

    from bench.latency import BenchRobot, _prepare, _request
    from hospital_delivery.celery import app

    # Nothing is sent to the worker with one robot (allocated in the request); were anything
    # sent, it goes to a queue of this process's own, forgotten at the end (_django_finish).
    app.conf.task_default_queue = f"hd-instructions-{uuid.uuid4().hex[:10]}"
    transport = _WsgiTransport(get_wsgi_application())
    tokens, fleet = _prepare(users=1, robots=1)
    robot = BenchRobot("http://127.0.0.1", *fleet[0], transport=transport)
    robot.client.heartbeat()
    nurse, rng = {"Authorization": f"Bearer {tokens[0]}"}, random.Random(1)

    def cycle() -> None:
        status, task = transport.post("http://127.0.0.1/api/v1/tasks/", _request(rng), nurse)
        if status != 201:
            raise SystemExit(f"request: {status} {task}")
        for _ in range(3):  # the plan; the delivery reported; the acknowledgements
            robot.client.heartbeat()
        if task["code"] not in robot.received or robot.client.unsent:
            raise SystemExit(f"{task['code']}: its delivery did not go round in three heartbeats")

    return cycle


def _django_finish() -> None:
    from django.conf import settings

    from bench.stack import queue_forget
    from core import outbox
    from hospital_delivery.celery import app

    outbox.drain(timeout=10)
    queue_forget(settings.REDIS_URL, app.conf.task_default_queue)


class _WsgiTransport:
    """A RobotClient transport (and the task API's) that calls the WSGI application itself."""

    def __init__(self, application):
        self.application = application

    def post(self, url: str, body: dict, headers: dict) -> tuple[int, dict | str]:
        data = json.dumps(body).encode()
        statuses: list[str] = []
        environ = _environ(urlsplit(url).path, data, headers.get("Authorization", ""))
        answer = b"".join(self.application(environ, lambda s, h, e=None: statuses.append(s)))
        try:
            return int(statuses[0].split()[0]), json.loads(answer)
        except ValueError:
            return int(statuses[0].split()[0]), answer.decode("utf-8", "replace")


def _child(step, count: int, warmup: int) -> None:
    """Run `step` (a heartbeat, a delivery cycle) `warmup` times, then under callgrind's
    instrumentation no time and `count` times, each window dumped; with -1, once more after
    the warm-up, printing the verb and table of each statement that one sent."""
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    for _ in range(warmup):
        step()
    if count >= 0:
        for steps in (0, count):  # the switching alone, then with the steps: the difference
            _callgrind("--instr=on")
            for _ in range(steps):
                step()
            _callgrind("--instr=off")
            _callgrind("--dump")
        return
    with CaptureQueriesContext(connection) as captured:
        step()
    print("|".join(_statement_name(query["sql"]) for query in captured.captured_queries))
    if connection.vendor != "postgresql":
        print("")
        return
    from core.pgtrace import round_trips

    with round_trips() as trips:
        step()
    print("|".join(_round_trip_name(trip) for trip in trips))


def _round_trip_name(trip: str) -> str:
    """A simple query's text, shortened: `SET LOCAL synchronous_commit TO OFF; COMMIT`
    stays whole, a statement prepared reads `prepared`."""
    return trip if len(trip) <= 60 else _statement_name(trip)


def _statement_name(sql: str) -> str:
    """`SELECT robots_robot`, `UPDATE robots_robot`, `COMMIT`: the verb and its table."""
    table = re.search(r'(?:FROM|UPDATE|INTO) "(\w+)"', sql)
    return f"{sql.split()[0]} {table.group(1)}" if table else " ".join(sql.split()[:2])


def _django_setup(database_url: str, **environment: str) -> None:
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        ALLOWED_HOSTS="127.0.0.1",
        LOG_LEVEL="WARNING",
        DATABASE_CONN_MAX_AGE="600",  # one connection, as a gunicorn worker keeps
        **environment,
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()


def _sender(database_url: str, robot: str):
    _django_setup(database_url)
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
        environ = _environ(f"/api/v1/robots/{robot}/heartbeat", body, f"Bearer {token}")
        answer = b"".join(application(environ, lambda s, h, e=None: statuses.append(s)))
        if not statuses[0].startswith("200"):
            raise SystemExit(f"heartbeat: {statuses[0]} {answer[:500]!r}")

    return send


def _environ(path: str, body: bytes, authorization: str) -> dict:
    """What gunicorn hands the application for a POST of a JSON body."""
    return {
        "REQUEST_METHOD": "POST",
        "PATH_INFO": path,
        "SCRIPT_NAME": "",
        "QUERY_STRING": "",
        "SERVER_NAME": "127.0.0.1",
        "SERVER_PORT": "8000",
        "SERVER_PROTOCOL": "HTTP/1.1",
        "REMOTE_ADDR": "127.0.0.1",
        "HTTP_HOST": "127.0.0.1",
        "CONTENT_TYPE": "application/json",
        "CONTENT_LENGTH": str(len(body)),
        "HTTP_AUTHORIZATION": authorization,
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
