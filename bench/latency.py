"""From a nurse's request to the robot holding its plan: the thesis' Tables 8.1-8.3, and better.

    python bench/latency.py            # 20 runs per row, up to 100 robots and users (minutes)
    python bench/latency.py --quick    # small counts, 1 run each: what CI runs
    python bench/latency.py --rows 100x100 --runs 5   # only the burst of 100 users

The thesis (Table 8.1-8.3) measured ~75 ms from a user's web request to the robot receiving
the command over a direct TCP connection, with 1 user and 1 device, 10/50/100 concurrent users,
and 10/50/100 devices. Here, on the production stack (bench/stack.py: gunicorn, daphne, a Celery
worker; PostgreSQL unless told otherwise): a "user" POSTs a task to /api/v1/tasks/ (the
server allocates it in the request itself when no other allocation runs on the site, else in
the Celery worker, and posts the plan on the robot's board) and the latency runs from just
before the POST until a heartbeat response hands the robot a plan carrying that task. Robots
are robotsim RobotClients heartbeating at 1 Hz, without and with the push channel (a wake-up
over the robot's websocket, then a heartbeat at once). They stay at their docks and report
each task done at once, so the next run finds them empty.

Rows: 1 user and 1 robot; N users at once (N = 10, 50, 100) with N robots, each run N POSTs at
the same instant (each needs a robot free to take it); N robots (10, 50, 100) heartbeating while
one user requests. Each row: `runs` runs, all their latencies pooled.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import random
import shlex
import statistics
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import requests

from bench import saving
from bench.stack import Stack, temporary_database
from robotsim.client import RobotClient, listen_for_wakes

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"
THESIS_MS = {"1 user, 1 robot": 75.35, "users": 75.55, "robots": 79.55}  # Tables 8.1, 8.2, 8.3


@dataclass(frozen=True)
class Row:
    users: int
    robots: int

    @property
    def label(self) -> str:
        if self.users == 1 and self.robots == 1:
            return "1 user, 1 robot"
        if self.users > 1:
            return f"{self.users} users at once"
        return f"{self.robots} robots"

    @property
    def thesis(self) -> float:
        if self.users == 1 and self.robots == 1:
            return THESIS_MS["1 user, 1 robot"]
        return THESIS_MS["users" if self.users > 1 else "robots"]


FULL_ROWS = [
    Row(1, 1),
    Row(10, 10),
    Row(50, 50),
    Row(100, 100),
    Row(1, 10),
    Row(1, 50),
    Row(1, 100),
]
QUICK_ROWS = [Row(1, 1), Row(3, 3)]


@dataclass
class Sample:
    started: float  # time.time() just before the POST
    answered: float | None = None  # the POST's answer came back
    created: float | None = None  # the task row's created_at
    posted: float | None = None  # the first plan carrying it posted on the board
    received: float | None = None  # a heartbeat response handed it to the robot

    @property
    def latency(self) -> float:
        return self.received - self.started


@dataclass
class Outcome:
    row: Row
    push: bool
    samples: list[Sample] = field(default_factory=list)
    lost: int = 0  # requests whose plan never reached a robot in time


@saving.saves("latency")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small counts: for CI")
    parser.add_argument("--runs", type=int, help="runs per row (default 20; quick: 1)")
    parser.add_argument(
        "--database",
        default=os.environ.get("DATABASE_URL", "postgres://postgres@127.0.0.1:5432/postgres"),
        help="a PostgreSQL server to create the benchmark's database on (or sqlite:///)",
    )
    parser.add_argument("--web-workers", type=int, default=3, help="gunicorn sync workers")
    parser.add_argument(
        "--rows",
        type=_row,
        nargs="+",
        metavar="USERSxROBOTS",
        help="only these rows, e.g. 100x100 (the burst of 100 users) or 1x1",
    )
    parser.add_argument(
        "--push", choices=["no", "yes", "both"], default="both", help="without, with or both"
    )
    saving.add_argument(parser)
    args = parser.parse_args(argv)
    rows = args.rows or (QUICK_ROWS if args.quick else FULL_ROWS)
    pushes = {"no": (False,), "yes": (True,), "both": (False, True)}[args.push]
    runs = args.runs or (1 if args.quick else 20)
    os.environ.setdefault("SECRET_KEY", "bench-only")  # for the servers and manage.py too
    with temporary_database(args.database) as url:
        _django(url)
        users, robots = _prepare(max(r.users for r in rows), max(r.robots for r in rows))
        with Stack(database_url=url, web_workers=args.web_workers, conn_max_age=60) as stack:
            _print_header(stack, url, runs, argv)
            outcomes = []
            for row in rows:
                for push in pushes:
                    outcomes.append(_measure(stack, row, push, runs, users, robots))
    _print_table(outcomes)
    return 0 if all(o.samples and not o.lost for o in outcomes) else 1


def _row(text: str) -> Row:
    users, _, robots = text.partition("x")
    try:
        return Row(int(users), int(robots))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not USERSxROBOTS, e.g. 100x100") from None


# --- Setting up ---------------------------------------------------------------------------------


def _django(database_url: str) -> None:
    os.environ["DATABASE_URL"] = database_url
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")
    import django

    django.setup()


def _prepare(users: int, robots: int) -> tuple[list[str], list[tuple[str, str, str]]]:
    """The Eulji site, `robots` robots at its docks and `users` staff users; their tokens."""
    from django.contrib.auth import get_user_model

    from hospital_delivery.models import ApiToken
    from robots.models import Robot
    from robots.services import robot_token_issue
    from robots.sitefile import site_file_read, site_load

    site = site_load(data=site_file_read(SITE_FILE))
    docks = list(site.waypoints.filter(kind="dock").order_by("code"))
    fleet = list(Robot.objects.filter(site=site).order_by("code"))
    for n in range(len(fleet), robots):
        fleet.append(Robot.objects.create(site=site, code=f"B{n + 1:03d}", dock=docks[n % 4]))
    tokens = [(r.code, robot_token_issue(robot=r), r.dock.code) for r in fleet[:robots]]
    User = get_user_model()
    staff = [User.objects.create_user(f"nurse{n:03d}", is_staff=True) for n in range(users)]
    return [ApiToken.issue(user) for user in staff], tokens


def _print_header(stack: Stack, url: str, runs: int, argv) -> None:
    from django.conf import settings

    now = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    command = shlex.join(["python", "bench/latency.py", *(argv if argv else sys.argv[1:])])
    database = "PostgreSQL" if url.startswith("postgres") else "SQLite"
    print(f"latency benchmark  {now}")
    print(f"command: {command}")
    print(f"Python {platform.python_version()}, {os.cpu_count()} CPUs, {platform.platform()}")
    print(f"server: {stack.description}; {database}")
    print(
        f"allocation: ALLOCATION_POLICY={settings.ALLOCATION_POLICY}, "
        f"ALLOCATE_ON_REQUEST={'on' if settings.ALLOCATE_ON_REQUEST else 'off'}"
    )
    print("robots and users: threads of this process, on the same machine as the server")
    print(f"{runs} runs per row; heartbeat interval 1 s\n")


# --- Measuring ----------------------------------------------------------------------------------


class BenchRobot:
    """A RobotClient at its dock that notes when a plan brings each task, and reports every
    task done at once (loaded, unloaded, completed) so that it is empty for the next run."""

    def __init__(self, server_url: str, code: str, token: str, dock: str, transport=None):
        self.client = RobotClient(
            server_url=server_url, robot=code, token=token, transport=transport
        )
        self.client.update_state(status="idle", floor="15F", waypoint=dock, battery=1.0)
        self.token = token
        self.received: dict[str, float] = {}
        self.client.on("plan", self._on_plan)

    def _on_plan(self, plan: dict) -> None:
        now = time.time()
        for stop in plan["stops"]:
            task = stop.get("task")
            if task and task not in self.received:
                self.received[task] = now
                self._deliver(plan, task)

    def _deliver(self, plan: dict, task: str) -> None:
        for stop in plan["stops"]:
            if stop.get("task") == task:
                done = "loaded" if stop["action"] == "pickup" else "unloaded"
                self.client.event(done, task=task, stop=stop["stop"])
        self.client.event("task_completed", task=task)


def _measure(stack: Stack, row: Row, push: bool, runs: int, users, fleet) -> Outcome:
    robots = [
        BenchRobot(stack.http_url, code, token, dock) for code, token, dock in fleet[: row.robots]
    ]
    stop = threading.Event()
    threads = [threading.Thread(target=_heartbeat, args=(r, stop), daemon=True) for r in robots]
    if push:
        threads += [
            threading.Thread(
                target=listen_for_wakes,
                args=(r.client,),
                kwargs={"ws_url": stack.ws_url, "token": r.token, "stop": stop},
                daemon=True,
            )
            for r in robots
        ]
    for thread in threads:
        thread.start()
    outcome = Outcome(row, push)
    try:
        _wait(lambda: all(r.client.seq >= 2 for r in robots), 30, "robots heartbeating")
        time.sleep(0.5)  # push channels connected
        sessions = [_session(token) for token in users[: row.users]]
        rng = random.Random(f"{row}-{push}")
        for _ in range(runs):
            _run(stack, sessions, robots, rng, outcome)
    finally:
        stop.set()
        for robot in robots:
            robot.client.wake.set()
        for thread in threads:
            thread.join(timeout=5)
    return outcome


def _heartbeat(robot: BenchRobot, stop: threading.Event) -> None:
    stop.wait(random.random())  # robots do not all start in the same instant
    robot.client.run(stop=stop)


def _session(token: str) -> requests.Session:
    session = requests.Session()
    session.headers["Authorization"] = f"Bearer {token}"
    return session


def _run(stack: Stack, sessions, robots: list[BenchRobot], rng, outcome: Outcome) -> None:
    """Every user POSTs one task at the same instant; wait for each to reach its robot."""
    bodies = [_request(rng) for _ in sessions]
    barrier = threading.Barrier(len(sessions))
    codes: dict[str, Sample] = {}

    def order(session, body):
        barrier.wait()
        started = time.time()
        response = session.post(f"{stack.http_url}/api/v1/tasks/", json=body, timeout=60)
        response.raise_for_status()
        codes[response.json()["code"]] = Sample(started, answered=time.time())

    users = [
        threading.Thread(target=order, args=pair) for pair in zip(sessions, bodies, strict=True)
    ]
    for thread in users:
        thread.start()
    for thread in users:
        thread.join()
    received = {}
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and len(received) < len(codes):
        for robot in robots:
            received.update({c: t for c, t in robot.received.items() if c in codes})
        time.sleep(0.01)
    for code, sample in codes.items():
        sample.received = received.get(code)
    _server_times(codes)
    outcome.samples += [s for s in codes.values() if s.received is not None]
    outcome.lost += sum(s.received is None for s in codes.values())
    _wait(lambda: _all_finished(codes), 60, "the run's tasks completed", lambda: _unfinished(codes))
    # Start the next run at a random moment of the robots' heartbeat cycle: runs that followed
    # each other at once would fall at the same phase every time.
    time.sleep(0.2 + rng.random())


def _request(rng: random.Random) -> dict:
    stations = ["6F-WARD-A", "9F-WARD-B", "2F-LAB-DROP", "1F-PHARM", "3F-ICU", "12F-WARD-A"]
    pickup, dropoff = rng.sample(stations, 2)
    return {
        "sender": "Ward",
        "receiver": "Laboratory",
        "contents": "Blood samples",
        "pickups": [pickup],
        "dropoffs": [dropoff],
    }


def _server_times(samples: dict[str, Sample]) -> None:
    """When the server created each task and first posted a plan carrying it."""
    from boards.models import BoardMessage
    from scheduling.models import Task

    for code, sample in samples.items():
        task = Task.objects.with_code(code).first()
        plan = (
            BoardMessage.objects.filter(type="plan", body__tasks__has_key=code)
            .order_by("posted_at")
            .first()
        )
        sample.created = task.created_at.timestamp() if task else None
        sample.posted = plan.posted_at.timestamp() if plan else None


def _all_finished(samples: dict[str, Sample]) -> bool:
    return not _not_completed(samples).exists()


def _unfinished(samples: dict[str, Sample]) -> str:
    """The run's tasks not completed: code, status and robot, for the timeout's message."""
    left = _not_completed(samples).select_related("robot")
    return ", ".join(f"{t.code} {t.status} {t.robot and t.robot.code}" for t in left)


def _not_completed(samples: dict[str, Sample]):
    from scheduling.models import Task

    pks = [int(code[2:]) for code in samples]
    return Task.objects.filter(pk__in=pks).exclude(status="completed")


def _wait(check, timeout: float, what: str, explain=None) -> None:
    """Poll `check` until it holds; past the timeout, raise, with explain() if given."""
    deadline = time.monotonic() + timeout
    while not check():
        if time.monotonic() > deadline:
            detail = f" ({explain()})" if explain else ""
            raise TimeoutError(f"{what}: not within {timeout} s{detail}")
        time.sleep(0.02)


# --- Reporting ----------------------------------------------------------------------------------


def _print_table(outcomes: list[Outcome]) -> None:
    print(
        f"\n{'':<20}{'push':>5}{'n':>6}{'mean':>9}{'p50':>9}{'p99':>9}"
        f"{'->posted':>10}{'->robot':>9}{'answer':>8}{'thesis':>8}"
    )
    for n, o in enumerate(outcomes):
        latencies = [s.latency * 1000 for s in o.samples]
        to_posted = [(s.posted - s.started) * 1000 for s in o.samples if s.posted]
        to_robot = [(s.received - s.posted) * 1000 for s in o.samples if s.posted]
        answer = [(s.answered - s.started) * 1000 for s in o.samples]
        label = o.row.label if n == 0 or outcomes[n - 1].row != o.row else ""
        print(
            f"{label:<20}{'yes' if o.push else 'no':>5}{len(latencies):>6}"
            f"{_ms(statistics.fmean(latencies)):>9}{_ms(_percentile(latencies, 50)):>9}"
            f"{_ms(_percentile(latencies, 99)):>9}{_ms(statistics.fmean(to_posted)):>10}"
            f"{_ms(statistics.fmean(to_robot)):>9}{_ms(statistics.fmean(answer)):>8}"
            f"{_ms(o.row.thesis):>8}" + (f"  ({o.lost} lost)" if o.lost else "")
        )
    print(
        "\nms. mean/p50/p99: from just before the POST to the heartbeat response carrying the\n"
        "plan. ->posted: mean from the POST to the plan posted on the board (the request and the\n"
        "allocation, in the request or, if another runs, in the worker after a queue wait);\n"
        "->robot: mean from then to the robot holding it (with push, the wake is sent as the\n"
        "plan is posted and the woken heartbeat waits for the commit). Without push the\n"
        "robot sees the plan at its next heartbeat, on average half an interval (~500 ms of the\n"
        "1 s interval) later; with push it heartbeats as soon as it is woken, and the interval\n"
        "plays no part. answer: mean from the POST to its answer (the user's wait). thesis:\n"
        "the mean of the thesis' Table 8.1, 8.2 or 8.3 (direct TCP)."
    )


def _ms(value: float) -> str:
    return f"{value:.0f}" if value >= 100 else f"{value:.1f}"


def _percentile(values: list[float], percent: float) -> float:
    ordered = sorted(values)
    return ordered[max(math.ceil(percent / 100 * len(ordered)) - 1, 0)]


if __name__ == "__main__":
    sys.exit(main())
