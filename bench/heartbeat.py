"""Heartbeat throughput: N robots at 1 Hz against the production stack, and a bare endpoint.

    python bench/heartbeat.py            # 100, 200, 500, 1000 robots, PostgreSQL (8 minutes)
    python bench/heartbeat.py --quick    # 20 robots, short: what CI runs
    python bench/heartbeat.py --database sqlite:///    # the default database instead
    python bench/heartbeat.py --robots 500 --floor       # and the least a heartbeat can do

The server runs as the README recommends for production (bench/stack.py): gunicorn sync workers (2 x
CPUs + 1 with PostgreSQL, as the README advises; 3 with SQLite, as the Procfile; 2 with --quick),
daphne, a Celery worker and Celery beat (the sweeps run every second, as in production), on a fresh
database. Each simulated robot heartbeats once a second (phases spread over the second) with a
realistic body (state at its dock, no events), waiting for each answer and then the interval it told
before the next, as the protocol asks; when the server falls behind the robots fall behind with it,
so "achieved" is what the server sustains. Each robot keeps one boot_id, its seq rising, for the
whole run (all rows), as a running fleet does: it does not restart every row, and the first
heartbeat of a boot costs more queries (a new boot every row would make a third of the heartbeats at
1000 robots first ones). In the same run the same load goes to `POST /bench/bare`, a DRF view that
returns `{}` (no authentication, no database): the ratio is what the heartbeat's own work costs.
With --floor, a third row per count goes to `POST /bench/floor/<code>` (bench/urls.py), the least a
heartbeat kept in the database can do: the bare endpoint's throughput is out of reach of any such
heartbeat, the floor's is not.

The load generator is one asyncio process with raw HTTP/1.1 (a connection per request: gunicorn's
sync workers close each one), sending through nginx as robots do in production. It shares the
2-core machine with the server; its own CPU use is printed so it can be seen not to be the
bottleneck. Sent straight to gunicorn (--direct), the load meets gunicorn lingering after each
answer until its client closes (gunicorn 27): a generator slowed by hundreds of connections
holds the workers in that wait, 40 % of their time with 300 robots on a 2-core machine (py-spy),
against 3 % through nginx, which closes at once.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import datetime
import json
import math
import os
import platform
import shlex
import sys
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving
from bench.stack import SilentRedis, Stack, temporary_database

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"
TIMEOUT = 10.0  # seconds before a heartbeat counts as an error


@dataclass
class Boot:
    """A robot's boot: one for the whole run, its seq rising across rows, and the heartbeat
    interval it was last told, which it keeps from one row to the next as a running robot does
    (1 s until told, as the protocol says)."""

    id: str = field(default_factory=lambda: uuid.uuid4().hex)
    seq: int = 0
    interval: float = 1.0


BOOTS: dict[str, Boot] = {}  # robot code -> its boot


@dataclass(frozen=True)
class Settings:
    counts: tuple[int, ...]
    warmup: float
    measure: float
    stalled: int  # robots of the Redis-stalled pair of rows
    direct: bool = False  # the load straight to gunicorn, not through nginx
    # A load before each stack's rows, so that every web worker has loaded the application.
    warm: bool = True
    web_workers: int | None = None  # None: as the README advises for production


# A row's robots that were not in the row before start together, and their first heartbeats
# (new boots, or presence coming back after the bare row) cost more: the learned interval takes
# 20-40 s to settle after that (bench/heartbeat.py --timeline), and a row measures
# the fleet once settled (3 s until then).
FULL = Settings(counts=(100, 200, 500, 1000), warmup=30.0, measure=15.0, stalled=100)
# Quick: rows that only show the benchmark still runs, on stacks that start quickly.
QUICK = Settings(counts=(20,), warmup=1.0, measure=2.0, stalled=20, warm=False, web_workers=2)


@dataclass
class Load:
    robots: int
    endpoint: str
    seconds: float
    latencies: list[float] = field(default_factory=list)  # of answers in the window, seconds
    errors: dict[str, int] = field(default_factory=dict)
    loader_cpu: float = 0.0  # share of one core
    flips: int = 0  # robots flipped unreachable while measured (PresenceChange rows)
    told: list[float] = field(default_factory=list)  # heartbeat_interval of answers, seconds
    push: list[float] = field(default_factory=list)  # plan posted -> in a probe's hands, s
    push_lost: int = 0  # plans posted that no probe received within PUSH_DEADLINE
    # (seconds from the row's start, latency, interval told) of every answer (--timeline)
    answers: list[tuple[float, float, float]] = field(default_factory=list)
    queue: list[tuple[float, int]] = field(default_factory=list)  # (seconds, connections)

    @property
    def achieved(self) -> float:
        return len(self.latencies) / self.seconds

    def error(self, kind: str) -> None:
        self.errors[kind] = self.errors.get(kind, 0) + 1


@saving.saves("heartbeat")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small counts, short: for CI")
    parser.add_argument(
        "--database",
        default=os.environ.get("DATABASE_URL", "postgres://postgres@127.0.0.1:5432/postgres"),
        help="a PostgreSQL server to create the benchmark's database on, or sqlite:///",
    )
    parser.add_argument("--web-workers", type=int, help="gunicorn sync workers")
    parser.add_argument("--robots", type=int, nargs="+", help="rows to run, e.g. --robots 500")
    parser.add_argument(
        "--no-stalled-redis",
        dest="stalled_redis",
        action="store_false",
        help="skip the two rows with Redis answering and stalled",
    )
    parser.add_argument(
        "--capacity",
        type=int,
        help="the server's HEARTBEAT_CAPACITY, the operator's ceiling (heartbeats/s; below it "
        "the server lengthens the interval when saturated; 0: robots always told 1 s; default "
        "$HEARTBEAT_CAPACITY or settings.py's 1000, and 0 with --quick)",
    )
    parser.add_argument("--warmup", type=float, help="seconds of each row before measuring")
    parser.add_argument("--measure", type=float, help="seconds measured per row")
    parser.add_argument(
        "--direct",
        action="store_true",
        help="send the robots' load straight to gunicorn, not through nginx as in production",
    )
    parser.add_argument(
        "--floor",
        action="store_true",
        help="a third row per count: the least a heartbeat kept in the database can do "
        "(one transaction in plain SQL, bench/urls.py)",
    )
    parser.add_argument(
        "--timeline",
        action="store_true",
        help="after the table, each heartbeat row second by second: answers, latency, the "
        "interval told and the connections waiting for a worker",
    )
    saving.add_argument(parser)
    args = parser.parse_args(argv)
    if args.capacity is None:
        # --quick: rows of a few seconds on a stack just started. Its first requests wait for
        # workers still loading, which would tell the robots an interval longer than a row.
        args.capacity = 0 if args.quick else int(os.environ.get("HEARTBEAT_CAPACITY", 1000))
    settings = QUICK if args.quick else FULL
    settings = dataclasses.replace(
        settings,
        counts=tuple(args.robots or settings.counts),
        warmup=settings.warmup if args.warmup is None else args.warmup,
        measure=settings.measure if args.measure is None else args.measure,
        stalled=args.robots[0] if args.robots else settings.stalled,
        direct=args.direct,
    )
    postgres = not args.database.startswith("sqlite")
    endpoints = ("heartbeat", "floor", "bare") if args.floor else ("heartbeat", "bare")
    workers = (
        args.web_workers or settings.web_workers or ((2 * os.cpu_count() + 1) if postgres else 3)
    )
    os.environ.setdefault("SECRET_KEY", "bench-only")  # for the servers and manage.py too
    with temporary_database(args.database) as url:
        stack = Stack(
            database_url=url,
            web_workers=workers,
            beat=True,
            conn_max_age=60,
            env={"HEARTBEAT_CAPACITY": str(args.capacity)},
            proxy=True,  # robots talk to nginx, as in production (the load too, unless --direct)
        )
        # This process posts the probes' plans: its wake-ups must reach the stack's daphne.
        os.environ.update(CHANNELS_PREFIX=stack.channels_prefix, REDIS_URL=stack.redis_url)
        tokens = _robots(url, max(settings.counts) + PUSH_PROBES)
        probes, tokens = tokens[-PUSH_PROBES:], tokens[:-PUSH_PROBES]
        with stack:
            _print_header(stack, postgres, settings, argv, args.capacity)
            if settings.warm:
                _load(stack, tokens[: settings.counts[0]], "heartbeat", settings)
            loads = []
            with PushProbes(stack, probes) as push:
                for count in settings.counts:
                    for endpoint in endpoints:
                        loads.append(_load(stack, tokens[:count], endpoint, settings, push))
        stalled = (
            _redis_stalled_rows(url, workers, tokens[: settings.stalled], settings)
            if (args.stalled_redis)
            else []
        )
    _print_table(loads)
    if args.timeline:
        _print_timelines(loads)
    if stalled:
        _print_stalled(stalled)
    return 0 if all(load.latencies for load in [*loads, *stalled]) else 1


def _redis_stalled_rows(url: str, workers: int, robots, settings: Settings) -> list[Load]:
    """The same heartbeats from web servers alone (no Celery, no daphne), with Redis answering,
    then with a Redis that accepts connections and never answers (bench.stack.SilentRedis)."""
    loads = []
    with SilentRedis() as silent:
        for redis_url in (None, silent.url):
            stack = Stack(
                database_url=url,
                redis_url=redis_url,
                web_workers=workers,
                daphne=False,
                worker=False,
                conn_max_age=60,
                # Every robot at 1 Hz, whatever the rows before left not yet offline.
                env={"HEARTBEAT_CAPACITY": "0"},
            )
            with stack:
                if settings.warm:
                    _load(stack, robots, "heartbeat", settings)
                loads.append(_load(stack, robots, "heartbeat", settings))
    return loads


def _robots(database_url: str, count: int) -> list[tuple[str, str]]:
    """The Eulji site and `count` robots at its docks; (code, token) of each."""
    os.environ["DATABASE_URL"] = database_url
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")
    import django

    django.setup()
    from core.tokens import token_new
    from robots.models import Robot
    from robots.sitefile import site_file_read, site_load

    site = site_load(data={**site_file_read(SITE_FILE), "robots": []})
    docks = list(site.waypoints.filter(kind="dock").order_by("code"))
    tokens, robots = [], []
    for n in range(count):
        token, hashed = token_new()
        code = f"H{n + 1:04d}"
        tokens.append((code, token))
        robots.append(Robot(site=site, code=code, dock=docks[n % len(docks)], token_hash=hashed))
    Robot.objects.bulk_create(robots)
    return tokens


def _print_header(stack: Stack, postgres: bool, settings: Settings, argv, capacity: int) -> None:
    now = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    command = shlex.join(["python", "bench/heartbeat.py", *(argv if argv else sys.argv[1:])])
    print(f"heartbeat benchmark  {now}")
    print(f"command: {command}")
    print(f"Python {platform.python_version()}, {os.cpu_count()} CPUs, {platform.platform()}")
    print(f"server: {stack.description}; {'PostgreSQL' if postgres else 'SQLite (WAL)'}")
    print(
        f"HEARTBEAT_CAPACITY={capacity} (the operator's ceiling of heartbeats/s; below it the "
        "wait for a worker stretches the interval, core/overload.py)"
    )
    path = "straight to gunicorn" if settings.direct else "through nginx, as in production"
    print(
        f"load: robots at 1 Hz each unless told longer, phases spread over the second,\n"
        f"{settings.warmup:g} s warm-up then {settings.measure:g} s measured per row; one asyncio "
        f"process with raw HTTP/1.1, {path},\non the same {os.cpu_count()}-core machine as the "
        "server.\n"
    )


# --- Plans pushed under load ----------------------------------------------------------------------

PUSH_PROBES = 4  # robots with the push channel, beside the row's robots
PUSH_EVERY = 0.25  # seconds between plans posted to them
PUSH_DEADLINE = 10.0  # seconds for a probe to receive a plan before it counts as lost


class PushProbes:
    """A few robots speaking the whole protocol (robotsim's client: heartbeats at the interval
    told, the push channel, acks, `Woken-By` on a woken heartbeat) through nginx, as robots in
    production, while a row's robots load gunicorn directly. This process posts a plan to one of
    them every PUSH_EVERY seconds, as the scheduler would (boards.services board_post: the
    wake-up goes through Redis to daphne to the robot's socket), and times it from the post to
    the heartbeat answer that hands it to the robot."""

    def __init__(self, stack: Stack, robots):
        from robotsim.client import RobotClient

        self.stack, self.stop = stack, threading.Event()
        self.clients = [
            RobotClient(server_url=stack.proxy_url, robot=code, token=token)
            for code, token in robots
        ]
        self.tokens = dict(robots)
        self.posted: dict[str, float] = {}
        self.received: dict[str, float] = {}
        self.poster: threading.Thread | None = None
        self.version = 0
        for client in self.clients:
            client.update_state(status="idle", floor="15F", waypoint="15F-DOCK-1", battery=1.0)
            client.on("plan", self._received)

    def _received(self, message: dict) -> None:
        self.received.setdefault(message["id"], time.perf_counter())

    def __enter__(self) -> PushProbes:
        from robotsim.client import listen_for_wakes

        for client in self.clients:
            token = self.tokens[client.robot]
            kwargs = {"ws_url": self.stack.proxy_ws_url, "token": token, "stop": self.stop}
            threading.Thread(target=listen_for_wakes, args=(client,), kwargs=kwargs).start()
            threading.Thread(target=client.run, kwargs={"stop": self.stop}).start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        for client in self.clients:
            client.wake.set()

    def measure(self, *, after: float, seconds: float) -> None:
        """Post plans from `after` seconds from now, for `seconds` (in a thread)."""
        self.posted, self.received = {}, {}
        self.poster = threading.Thread(target=self._post, args=(after, seconds))
        self.poster.start()

    def _post(self, after: float, seconds: float) -> None:
        from boards.protocol import plan_body
        from boards.services import board_post
        from robots.models import Robot

        robots = {r.code: r for r in Robot.objects.filter(code__in=self.tokens)}
        self.stop.wait(after)
        end = time.perf_counter() + seconds
        for n in range(int(seconds / PUSH_EVERY)):
            client = self.clients[n % len(self.clients)]
            self.version += 1  # newer than any plan the probes have had
            body = plan_body(version=self.version, stops=[], tasks={})
            message = board_post(robot=robots[client.robot], type="plan", body=body, key="plan")
            self.posted[message.public_id] = time.perf_counter()
            self.stop.wait(max(end - seconds + (n + 1) * PUSH_EVERY - time.perf_counter(), 0))

    def results(self) -> tuple[list[float], int]:
        self.poster.join()
        deadline = time.perf_counter() + PUSH_DEADLINE
        while len(self.received.keys() & self.posted.keys()) < len(self.posted):
            if time.perf_counter() > deadline:
                break
            time.sleep(0.05)
        times = [self.received[m] - at for m, at in self.posted.items() if m in self.received]
        return times, len(self.posted) - len(times)


# --- The load -----------------------------------------------------------------------------------


def _load(stack: Stack, robots, endpoint: str, settings: Settings, push=None) -> Load:
    from robots.models import PresenceChange

    load = Load(len(robots), endpoint, settings.measure)
    cpu, wall = time.process_time(), time.perf_counter()
    started = datetime.datetime.now(datetime.UTC)
    if push and endpoint == "heartbeat":
        push.measure(after=0.5 + settings.warmup, seconds=settings.measure)
    port = stack.proxy_port if stack.proxy_port and not settings.direct else stack.http_port
    asyncio.run(_drive(port, stack.http_port, robots, endpoint, settings, load))
    if push and endpoint == "heartbeat":
        load.push, load.push_lost = push.results()
    load.loader_cpu = (time.process_time() - cpu) / (time.perf_counter() - wall)
    # Flips to unreachable after the warm-up, of this row's robots: robots silent during an
    # earlier row come back online in the warm-up, which is not a flip of this row's making.
    measured_from = started + datetime.timedelta(seconds=0.5 + settings.warmup)
    measured_to = measured_from + datetime.timedelta(seconds=settings.measure)
    codes = [code for code, _ in robots]
    load.flips = PresenceChange.objects.filter(
        robot__code__in=codes, new="unreachable", at__gte=measured_from, at__lt=measured_to
    ).count()
    return load


async def _drive(
    port: int, queue_port: int, robots, endpoint: str, settings: Settings, load: Load
) -> None:
    loop = asyncio.get_running_loop()
    begin = loop.time() + 0.5
    window = (begin + settings.warmup, begin + settings.warmup + settings.measure)
    count = len(robots)
    sampler = asyncio.create_task(_queue_sampled(queue_port, begin, load))
    driven = []
    for n, (code, token) in enumerate(robots):
        # Its first heartbeat of the row at its phase of the interval it was last told.
        first = begin + n / count * _interval_kept(code, endpoint)
        driven.append(_robot(port, code, token, endpoint, first, window, load, begin))
    await asyncio.gather(*driven)
    sampler.cancel()


def _interval_kept(code: str, endpoint: str) -> float:
    """The interval robot `code` heartbeats at as a row starts: the one it was last told (the
    bare endpoint tells none: 1 s)."""
    return BOOTS.setdefault(code, Boot()).interval if endpoint == "heartbeat" else 1.0


async def _queue_sampled(port: int, begin: float, load: Load) -> None:
    """Every QUEUE_EVERY seconds, the connections waiting for a worker on `port`."""
    loop = asyncio.get_running_loop()
    while True:
        load.queue.append((loop.time() - begin, listen_queue(port)))
        await asyncio.sleep(QUEUE_EVERY)


QUEUE_EVERY = 0.25


def listen_queue(port: int) -> int:
    """Connections waiting to be accepted on 127.0.0.1:`port` (Linux: /proc/net/tcp lists a
    listening socket's accept queue as its rx_queue); 0 where that cannot be read."""
    wanted = f"0100007F:{port:04X}"
    try:
        lines = Path("/proc/net/tcp").read_text().splitlines()[1:]
    except OSError:
        return 0
    for line in lines:
        fields = line.split()
        if fields[1] == wanted and fields[3] == "0A":  # state LISTEN
            return int(fields[4].split(":")[1], 16)
    return 0


async def _robot(port, code, token, endpoint, first, window, load: Load, begin: float) -> None:
    """One robot: a heartbeat from `first`, then each the interval it was told after the
    previous one's answer (1 s until told, and for the bare endpoint), as the protocol asks
    (docs/robot-protocol.md, "Interval"). Timed from the previous one's send instead (or at once
    if answered later), a robot whose heartbeat had queued would come back as much sooner than it
    was told, and robots leaving a backlog would come back together."""
    loop = asyncio.get_running_loop()
    boot, due, interval = BOOTS.setdefault(code, Boot()), first, _interval_kept(code, endpoint)
    path = {
        "heartbeat": f"/api/v1/robots/{code}/heartbeat",
        "floor": f"/bench/floor/{code}",
        "bare": "/bench/bare",
    }[endpoint]
    while due < window[1]:
        await asyncio.sleep(max(due - loop.time(), 0))
        boot.seq += 1
        sent = loop.time()
        request = _request(port, path, token, heartbeat_body(boot.id, boot.seq, code))
        try:
            status, body = await asyncio.wait_for(_exchange(port, request), TIMEOUT)
        except (TimeoutError, OSError, asyncio.IncompleteReadError, ValueError) as exc:
            status, body = type(exc).__name__, b""
        answered = loop.time()
        if status == 200 and endpoint == "heartbeat":
            interval = boot.interval = float(json.loads(body)["heartbeat_interval"])
            load.answers.append((answered - begin, answered - sent, interval))
        if window[0] <= sent and answered <= window[1]:
            if status == 200:
                load.latencies.append(answered - sent)
                load.told.append(interval)
            else:
                load.error(str(status))
        due = answered + interval  # the protocol's rule: the interval told after the answer


def heartbeat_body(boot: str, seq: int, code: str) -> bytes:
    """Robot `code`'s heartbeat at its dock (also bench/heartbeat_instructions.py's)."""
    n = int(code[1:])
    return json.dumps(
        {
            "boot_id": boot,
            "seq": seq,
            "sent_at": datetime.datetime.now(datetime.UTC).isoformat(),
            "state": {
                "status": "idle",
                "floor": "15F",
                "waypoint": f"15F-DOCK-{(n - 1) % 4 + 1}",
                "x": 70.0,
                "y": 26.0,
                "heading": 0.0,
                "battery": 0.9,
                "load": 0,
                "plan_version": 0,
                "errors": [],
            },
            "events": [],
            "acks": [],
            "requests": [],
        }
    ).encode()


def _request(port: int, path: str, token: str, body: bytes) -> bytes:
    head = (
        f"POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n"
        f"Authorization: Bearer {token}\r\nContent-Type: application/json\r\n"
        f"Content-Length: {len(body)}\r\n\r\n"
    )
    return head.encode() + body


async def _exchange(port: int, request: bytes) -> tuple[int, bytes]:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        writer.write(request)
        head = await reader.readuntil(b"\r\n\r\n")
        status = int(head.split(b" ", 2)[1])
        length = _content_length(head)
        body = await (reader.read() if length is None else reader.readexactly(length))
        return status, body
    finally:
        writer.close()


def _content_length(head: bytes) -> int | None:
    for line in head.split(b"\r\n"):
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"content-length":
            return int(value)
    return None


# --- Reporting ----------------------------------------------------------------------------------


def _print_table(loads: list[Load]) -> None:
    print(
        f"\n{'robots':>6}  {'endpoint':<10}{'offered/s':>10}{'achieved/s':>11}{'p50 ms':>8}"
        f"{'p99 ms':>8}{'errors':>8}{'loader CPU':>11}{'told s':>7}{'flips':>7}"
        f"{'push p50':>9}{'push max':>9}"
    )
    for load in loads:
        latencies = sorted(load.latencies)
        print(
            f"{load.robots:>6}  {'bare {}' if load.endpoint == 'bare' else load.endpoint:<10}"
            f"{load.robots:>10}{load.achieved:>11.0f}{_ms(latencies, 50):>8}{_ms(latencies, 99):>8}"
            f"{sum(load.errors.values()):>8}{load.loader_cpu:>11.0%}"
            f"{_percentile(load.told, 50):>7.1f}"
            f"{load.flips if load.endpoint == 'heartbeat' else '-':>7}"
            f"{_ms(load.push, 50) if load.push else '-':>9}"
            f"{_ms(load.push, 100) if load.push else '-':>9}"
            + (f"  ({load.push_lost} plans lost)" if load.push_lost else "")
            + (f"  {load.errors}" if load.errors else "")
        )
    print(
        "\noffered: heartbeats/s the robots would send at 1 Hz; they obey the interval each\n"
        "answer tells them (told s: the median told while measured, core/overload.py), so\n"
        "achieved is below offered when the server asks them to slow down.\n"
        "flips: robots flipped unreachable while measured (after the warm-up): a robot whose\n"
        "heartbeats come more than 3 told intervals apart is flipped by the sweep.\n"
        f"push: {PUSH_PROBES} more robots hold the push channel; a plan is posted to one of them "
        f"every {PUSH_EVERY:g} s\n"
        "while measured; ms from the post to the heartbeat answer handing it to the robot. They\n"
        "talk through nginx, which sends a woken heartbeat (Woken-By) to gunicorn's socket for\n"
        "those; the rows' robots to its regular one (or straight to it, with --direct)."
    )
    print("\nheartbeat (and floor) / bare endpoint under the same load:")
    rows: dict[int, dict[str, Load]] = {}
    for load in loads:
        rows.setdefault(load.robots, {})[load.endpoint] = load
    for robots, row in rows.items():
        print(f"{robots:>6} robots: {_against(row['heartbeat'], row['bare'])}")
        if "floor" in row:
            print(f"{robots:>6} robots, floor: {_against(row['floor'], row['bare'])}")


def _against(load: Load, bare: Load) -> str:
    ratio = load.achieved / bare.achieved if bare.achieved else float("nan")
    slower = _percentile(load.latencies, 50) / _percentile(bare.latencies, 50)
    return f"{ratio:.2f} of the bare endpoint's throughput, median latency x{slower:.1f}"


def _print_timelines(loads: list[Load]) -> None:
    """Each heartbeat row second by second, from its start (the warm-up included)."""
    for load in loads:
        if load.endpoint != "heartbeat":
            continue
        print(
            f"\n{load.robots} robots, second by second from the row's start (warm-up included)\n"
            f"{'s':>4}{'answers':>9}{'p50 ms':>9}{'max ms':>9}{'told s':>8}{'waiting':>9}"
        )
        seconds = int(max((at for at, _, _ in load.answers), default=0)) + 1
        for second in range(seconds):
            answers = [a for a in load.answers if second <= a[0] < second + 1]
            queue = [n for at, n in load.queue if second <= at < second + 1]
            latencies = [latency for _, latency, _ in answers]
            told = [interval for _, _, interval in answers]
            print(
                f"{second:>4}{len(answers):>9}"
                f"{_ms(latencies, 50) if answers else '-':>9}"
                f"{_ms(latencies, 100) if answers else '-':>9}"
                f"{_percentile(told, 50) if answers else float('nan'):>8.1f}"
                f"{max(queue, default=0):>9}"
            )


def _print_stalled(loads: list[Load]) -> None:
    answering, stalled = loads
    print(
        f"\nRedis stalled (accepts connections, never answers): {answering.robots} robots, web "
        "servers only\n"
        f"{'redis':<10}{'achieved/s':>11}{'p50 ms':>8}{'p99 ms':>8}{'errors':>8}"
    )
    for name, load in (("answering", answering), ("stalled", stalled)):
        latencies = sorted(load.latencies)
        print(
            f"{name:<10}{load.achieved:>11.0f}{_ms(latencies, 50):>8}{_ms(latencies, 99):>8}"
            f"{sum(load.errors.values()):>8}"
        )
    rise = (_percentile(stalled.latencies, 99) - _percentile(answering.latencies, 99)) * 1000
    print(f"p99 rise with Redis stalled: {rise:+.1f} ms")


def _percentile(values: list[float], percent: float) -> float:
    ordered = sorted(values)
    if not ordered:
        return float("nan")
    return ordered[max(math.ceil(percent / 100 * len(ordered)) - 1, 0)]


def _ms(latencies: list[float], percent: float) -> str:
    return f"{_percentile(latencies, percent) * 1000:.1f}"


if __name__ == "__main__":
    sys.exit(main())
