"""A simulated hospital day under every allocation policy, on the same request stream.

    python bench/fleet_day.py            # 08:00-20:00 on the Eulji demo site, 4 robots (minutes)
    python bench/fleet_day.py --quick    # 4 minutes of requests, 2 robots: what CI runs

The source paper's central claim (section 1): a robot that can take more tasks while it is out
(online multi-task allocation, on-MTA) delivers better than one that takes a new task only when
it is empty (single-task allocation, STA, how hospital fleets ran before). Measured here, as
settings.ALLOCATION_POLICY: `paper`, the paper's rule (a standby robot first, the one reaching
the pick-up soonest; else the robot whose route the task lengthens least), `least_travel` (the
least added travel, standby or not), `delivery_time` (ours: added travel plus the waiting it
causes) and `single` (STA). Every run gets the same seeded request stream
(robotsim.traffic.day_requests: a morning peak of laboratory samples, medication from the
pharmacy and medication rounds to several wards at 09:00, 13:00 and 17:00, sample kits,
supplies) and the same simulated robots and staff.

How it runs: time-accelerated and deterministic. Each policy runs in a process of its own with
the whole server in-process on a fresh SQLite database: robots (robotsim, the same simulator as
`manage.py simulate_fleet`) heartbeat through Django's test client (the full HTTP stack without
sockets), requests go through the public task API the same way, time is a virtual clock
(time_machine drives timezone.now()), and each simulated second the sweeps Celery beat would run
are called directly; a request is allocated in the request (settings.ALLOCATE_ON_REQUEST) and
anything enqueued for the worker runs eagerly on commit. It measures the policy, not the
broker. No network losses: they would cost every policy alike.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import random
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving  # noqa: E402
from bench.stack import manage  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"
DAY = datetime.date(2026, 3, 2)  # a Monday
POLICIES = ("paper", "least_travel", "delivery_time", "single")


@dataclass(frozen=True)
class Settings:
    start: int  # the hour requests begin (site local time)
    minutes: int  # for how long requests come
    robots: int
    drain_hours: float  # time after the last request for the fleet to finish
    scale: float  # request rates x


FULL = Settings(start=8, minutes=12 * 60, robots=4, drain_hours=4, scale=1.0)
QUICK = Settings(start=8, minutes=4, robots=2, drain_hours=1, scale=2.0)
HOUSEKEEPING_EVERY = 5  # simulated seconds between the presence, lease and ack-timeout sweeps


@dataclass
class Result:
    policy: str
    requested: int
    completed: int
    completed_in_day: int
    to_dropoff: list[float]  # seconds, request to last drop-off, per delivered task
    to_pickup: list[float]  # seconds, request to first pick-up
    distance: float  # metres driven, all robots
    driving: float  # seconds driving
    riding: float  # seconds in the elevator
    rides: int
    last_delivery: float  # seconds after midnight
    per_robot: dict[str, int]  # deliveries completed by each robot
    wall: float  # real seconds the run took
    heartbeats: int
    priorities: list[str]  # per delivered task, as to_dropoff
    on_time: list[bool]  # per delivered task: dropped off by its due-by time
    eta_error: list[float]  # seconds, ETA when assigned minus actual drop-off, per delivered task
    eta_error_loaded: list[float]  # the same with the drop-off ETA as it stood when picked up
    charging_trips: int  # plans sending a robot to charge
    lowest_battery: float  # the lowest battery any robot reported


@saving.saves("fleet_day")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="4 minutes of requests, 2 robots: for CI"
    )
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--robots", type=int, help="1-4 (default 4; quick: 2)")
    parser.add_argument("--scale", type=float, help="request rates x this (default 1)")
    parser.add_argument("--minutes", type=int, help="requests for this long from 08:00")
    parser.add_argument("--child", choices=POLICIES, help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    saving.add_argument(parser)
    args = parser.parse_args(argv)
    settings = QUICK if args.quick else FULL
    settings = Settings(
        start=settings.start,
        minutes=args.minutes or settings.minutes,
        robots=args.robots or settings.robots,
        drain_hours=settings.drain_hours,
        scale=args.scale or settings.scale,
    )
    if args.child:
        result = _run_policy(args.child, settings, args.seed)
        Path(args.out).write_text(json.dumps(asdict(result)))
        return 0
    _print_header(settings, args.seed, argv)
    results = _run_all(args, settings)
    _print_table(results)
    return 0 if all(r.completed == r.requested for r in results) else 1


# --- The parent: the policies side by side -------------------------------------------------------


def _run_all(args, settings: Settings) -> list[Result]:
    """One process per policy (fresh Django, database and settings each), all at once. Each
    database is a copy of one migrated here: migrating takes longer than a quick day."""
    secret_key = os.environ.get("SECRET_KEY") or "bench-only"
    with tempfile.TemporaryDirectory(prefix="hd-fleet-day-") as directory:
        migrated = Path(directory) / "migrated.sqlite3"
        manage(
            *("migrate", "--noinput", "-v", "0"),
            database_url=f"sqlite:///{migrated}",
            env={"SECRET_KEY": secret_key},
        )
        running = {}
        for policy in POLICIES:
            shutil.copyfile(migrated, Path(directory) / f"{policy}.sqlite3")
            out = Path(directory) / f"{policy}.json"
            command = [
                *(sys.executable, str(Path(__file__).resolve()), "--child", policy),
                *("--out", str(out), "--seed", str(args.seed), "--robots", str(settings.robots)),
                *("--scale", str(settings.scale), "--minutes", str(settings.minutes)),
                *(["--quick"] if args.quick else []),
            ]
            env = {
                **os.environ,
                "DATABASE_URL": f"sqlite:///{directory}/{policy}.sqlite3",
                "ALLOCATION_POLICY": policy,
                "PYTHONHASHSEED": "0",  # set iteration order: the same run every time
                "SECRET_KEY": secret_key,
                "LOG_LEVEL": "WARNING",
                # Robots heartbeat at the site's interval: the interval stretched by the wait
                # for a worker (core/overload.py) would follow this simulation's own CPU time,
                # not the simulated hospital's, and the day would not be the same twice.
                "HEARTBEAT_CAPACITY": "0",
            }
            running[policy] = (subprocess.Popen(command, cwd=ROOT, env=env), out)
        results = []
        for policy, (process, out) in running.items():
            if process.wait() != 0:
                raise SystemExit(f"the {policy} run failed (exit {process.returncode})")
            results.append(Result(**json.loads(out.read_text())))
        return results


def _print_header(settings: Settings, seed: int, argv) -> None:
    now = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    command = shlex.join(["python", "bench/fleet_day.py", *(argv if argv else sys.argv[1:])])
    print(f"fleet day benchmark  {now}")
    print(f"command: {command}")
    print(f"Python {platform.python_version()}, {os.cpu_count()} CPUs, {platform.platform()}")
    end = _clock(settings.start * 3600 + settings.minutes * 60)
    print(
        f"Eulji demo site, robots R1-R{settings.robots}, requests {settings.start:02d}:00-{end} "
        f"(seed {seed}, rates x{settings.scale:g}), then up to {settings.drain_hours:g} h "
        "to finish."
    )
    print(
        "Time-accelerated and deterministic: the server in-process (Django test client, SQLite),\n"
        "a virtual clock (time_machine), the due sweep called each simulated second (the others\n"
        "every 5 s), allocation in the request or eager on commit, robots heartbeating at the\n"
        "site's interval (HEARTBEAT_CAPACITY=0: no interval learned from this process's load).\n"
        "Same request stream, robots and staff delays for every policy; no network losses.\n"
    )


def _print_table(results: list[Result]) -> None:
    by_policy = {result.policy: result for result in results}
    rows = [
        ("deliveries requested", lambda r: f"{r.requested}"),
        ("completed (all)", lambda r: f"{r.completed}"),
        ("completed by end of day", lambda r: f"{r.completed_in_day}"),
        ("request -> drop-off, mean", lambda r: _minutes(statistics.fmean(r.to_dropoff))),
        ("request -> drop-off, p90", lambda r: _minutes(_p90(r.to_dropoff))),
        ("request -> pick-up, mean", lambda r: _minutes(statistics.fmean(r.to_pickup))),
        *_priority_rows(),
        ("ETA error |p50|, assigned", lambda r: _minutes(_percentile(_abs(r.eta_error), 0.5))),
        ("ETA error |p90|, assigned", lambda r: _minutes(_percentile(_abs(r.eta_error), 0.9))),
        ("ETA error mean, assigned", lambda r: _minutes(_mean(r.eta_error))),
        (
            "ETA error |p50|, picked up",
            lambda r: _minutes(_percentile(_abs(r.eta_error_loaded), 0.5)),
        ),
        (
            "ETA error |p90|, picked up",
            lambda r: _minutes(_percentile(_abs(r.eta_error_loaded), 0.9)),
        ),
        ("ETA error mean, picked up", lambda r: _minutes(_mean(r.eta_error_loaded))),
        ("robot travel, distance", lambda r: f"{r.distance / 1000:.1f} km"),
        ("robot travel, driving", lambda r: f"{r.driving / 3600:.1f} h"),
        ("elevator rides", lambda r: f"{r.rides} ({r.riding / 3600:.1f} h)"),
        ("charging trips", lambda r: f"{r.charging_trips}"),
        ("lowest battery", lambda r: f"{100 * r.lowest_battery:.0f} %"),
        ("deliveries per robot", lambda r: "/".join(str(n) for n in r.per_robot.values())),
        ("last drop-off", lambda r: _clock(r.last_delivery)),
        ("real time of the run", lambda r: f"{r.wall:.0f} s"),
        ("heartbeats", lambda r: f"{r.heartbeats}"),
    ]
    columns = [by_policy[policy] for policy in POLICIES]
    single = by_policy["single"]
    print(f"{'':<27}" + "".join(f"{policy:>15}" for policy in POLICIES))
    for label, show in rows:
        cells = "".join(f"{show(result):>15}" for result in columns)
        print(f"{label:<27}{cells}")
    print(f"\nratio to single{'':<12}" + "".join(f"{policy:>15}" for policy in POLICIES))
    for label in RATIOS:
        cells = "".join(f"{_ratio(label, result, single):>15}" for result in columns)
        print(f"{label:<27}{cells}")
    print(
        "\npaper: the source paper's rule (Sec. 3.1.2): a standby robot (holding no task) first,\n"
        "the one reaching the pick-up soonest, else the robot whose route the task lengthens\n"
        "least; least_travel: the robot whose route the task lengthens least, standby or not;\n"
        "delivery_time: added travel plus the waiting it causes (the default); single: a robot\n"
        "takes a task only when it holds none (single-task allocation).\n"
        "On time: dropped off by its due-by time (the site's default for its priority).\n"
        "ETA error: the drop-off ETA a task was given when assigned (and, picked up: its drop-off\n"
        "ETA as recomputed when it was loaded) minus its actual drop-off (|p50|, |p90|: of the\n"
        "absolute error; mean: negative = later than predicted)."
    )


RATIOS = {
    "request -> drop-off, mean": lambda r: statistics.fmean(r.to_dropoff),
    "request -> drop-off, p90": lambda r: _p90(r.to_dropoff),
    "request -> pick-up, mean": lambda r: statistics.fmean(r.to_pickup),
    "robot travel, distance": lambda r: r.distance,
    "robot travel, driving": lambda r: r.driving,
    "elevator rides": lambda r: r.rides,
}


def _ratio(label: str, a: Result, b: Result) -> str:
    value = RATIOS.get(label)
    if value is None or not value(b):
        return ""
    return f"{value(a) / value(b):.2f}"


PRIORITIES = ("stat", "urgent", "routine")


def _priority_rows():
    """Per priority: deliveries, mean and p90 request -> drop-off, share on time."""
    rows = []
    for priority in PRIORITIES:

        def of(r: Result, priority=priority) -> list[int]:
            return [n for n, p in enumerate(r.priorities) if p == priority]

        rows += [
            (f"{priority}: delivered", lambda r, of=of: f"{len(of(r))}"),
            (
                f"{priority}: -> drop-off mean",
                lambda r, of=of: _minutes(_mean([r.to_dropoff[n] for n in of(r)])),
            ),
            (
                f"{priority}: -> drop-off p90",
                lambda r, of=of: _minutes(_p90([r.to_dropoff[n] for n in of(r)])),
            ),
            (f"{priority}: on time", lambda r, of=of: _share([r.on_time[n] for n in of(r)])),
        ]
    return rows


def _mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def _share(flags: list[bool]) -> str:
    return f"{100 * sum(flags) / len(flags):.0f} %" if flags else "-"


def _abs(values: list[float]) -> list[float]:
    return [abs(v) for v in values]


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def _clock(seconds: float) -> str:
    moment = datetime.datetime.combine(DAY, datetime.time()) + datetime.timedelta(seconds=seconds)
    return moment.strftime("%H:%M")


def _p90(values: list[float]) -> float:
    return _percentile(values, 0.9)


def _percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[max(math.ceil(share * len(ordered)) - 1, 0)] if ordered else float("nan")


# --- A child: one policy, one day ---------------------------------------------------------------


def _run_policy(policy: str, settings: Settings, seed: int) -> Result:
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")
    import django

    django.setup()
    from django.conf import settings as django_settings

    assert policy == django_settings.ALLOCATION_POLICY
    django_settings.CHANNEL_LAYERS = {}  # nobody watches: no live pushes
    from hospital_delivery.celery import app

    app.conf.task_always_eager = True  # allocation on commit, in this process
    day = _Day(settings, seed)
    started = time.perf_counter()
    day.run()
    return day.result(policy, wall=time.perf_counter() - started)


class _Day:
    """The server, the robots and the request stream of one simulated day."""

    def __init__(self, settings: Settings, seed: int):
        from zoneinfo import ZoneInfo

        import time_machine

        from bench.inprocess import SERVER_URL, InProcessTaskApi, InProcessTransport
        from hospital_delivery.models import ApiToken
        from robots.models import Robot
        from robots.router import Router, site_map_from_file
        from robots.services import robot_token_issue
        from robots.sitefile import site_file_read, site_load
        from robotsim.client import RobotClient
        from robotsim.simulator import Behaviour, ManualClock, RobotLoop, SimRobot
        from robotsim.traffic import Stations, day_requests

        self.settings = settings
        self.start = datetime.datetime.combine(
            DAY, datetime.time(settings.start), tzinfo=ZoneInfo("Asia/Seoul")
        )
        self.travel = time_machine.travel(self.start, tick=False)
        self.traveller = self.travel.start()
        data = site_file_read(SITE_FILE)
        site = site_load(data=data)
        self.site_map = site_map_from_file(data)
        router = Router(self.site_map)
        self.clock = ManualClock()
        self.loops = []
        for robot in Robot.objects.filter(site=site).order_by("code")[: settings.robots]:
            client = RobotClient(
                server_url=SERVER_URL,
                robot=robot.code,
                token=robot_token_issue(robot=robot),
                transport=InProcessTransport(),
            )
            sim = SimRobot(
                client=client,
                site_map=self.site_map,
                dock=robot.dock.code,
                clock=self.clock,
                rng=random.Random(f"{seed}-{robot.code}"),
                router=router,
                behaviour=Behaviour.for_site(data),
            )
            self.loops.append(RobotLoop(sim))
        self.api = InProcessTaskApi(ApiToken.issue(_staff_user()))
        stations = Stations.of(self.site_map)
        self.day_end = settings.minutes * 60
        hours = (settings.start, settings.start + math.ceil(settings.minutes / 60))
        stream = day_requests(stations, seed=seed, hours=hours, scale=settings.scale)
        self.requests = [(at, body) for at, body in stream if at < self.day_end]
        self.codes: list[str] = []
        self.heartbeats = 0
        self.first_eta: dict[int, datetime.datetime] = {}  # task pk -> ETA when assigned
        self.loaded_eta: dict[int, datetime.datetime] = {}  # task pk -> drop-off ETA when loaded

    def run(self) -> None:
        from resources.leases import lease_sweep
        from robots.services import presence_sweep
        from scheduling.services import ack_timeout_sweep, due_sweep

        pending = list(self.requests)
        limit = self.day_end + self.settings.drain_hours * 3600
        second = 0
        try:
            while second < limit:
                second += 1
                self.clock.set(second)
                self.traveller.move_to(self.start + datetime.timedelta(seconds=second))
                while pending and pending[0][0] <= second:
                    self._order(pending.pop(0)[1])
                for loop in self.loops:
                    before = loop.client.seq
                    loop.step(second)
                    self.heartbeats += loop.client.seq - before
                if due_sweep():
                    self._note_etas()
                self._note_loaded_etas()
                if second % HOUSEKEEPING_EVERY == 0:
                    presence_sweep()
                    lease_sweep()
                    ack_timeout_sweep()
                if second >= self.day_end and second % 60 == 0 and self._all_done():
                    break
        finally:
            self.travel.stop()

    def _order(self, body: dict) -> None:
        status, reply = self.api.post(body)
        if status != 201:
            raise RuntimeError(f"request refused ({status}): {reply}")
        self.codes.append(reply["code"])
        self._note_etas()

    def _note_etas(self) -> None:
        """The ETA each task had when it was assigned (its first), to score it later."""
        _note_new_etas(self.first_eta)

    def _note_loaded_etas(self) -> None:
        """The drop-off ETA of each task as it stood when it was picked up (recomputed then)."""
        _note_new_etas(self.loaded_eta, picked_up_at__isnull=False)

    def _all_done(self) -> bool:
        from scheduling.models import Task

        unfinished = Task.objects.exclude(status__in=["completed", "cancelled", "failed"])
        return not unfinished.exists() and all(loop.robot.idle_at_dock for loop in self.loops)

    def result(self, policy: str, *, wall: float) -> Result:
        from boards.models import BoardMessage
        from scheduling.models import Task

        tasks = list(Task.objects.select_related("robot"))
        delivered = [t for t in tasks if t.delivered_at]
        day_end = self.start + datetime.timedelta(seconds=self.day_end)
        stats = [loop.robot.stats for loop in self.loops]
        last = max((t.delivered_at for t in delivered), default=self.start)
        return Result(
            policy=policy,
            requested=len(self.codes),
            completed=sum(t.status == "completed" for t in tasks),
            completed_in_day=sum(
                t.completed_at is not None and t.completed_at <= day_end for t in tasks
            ),
            to_dropoff=[(t.delivered_at - t.created_at).total_seconds() for t in delivered],
            to_pickup=[(t.picked_up_at - t.created_at).total_seconds() for t in delivered],
            distance=sum(s.distance for s in stats),
            driving=sum(s.moving for s in stats),
            riding=sum(s.riding for s in stats),
            rides=sum(s.rides for s in stats),
            last_delivery=(last - self.start).total_seconds() + self.settings.start * 3600,
            per_robot={
                loop.robot.code: sum(t.robot and t.robot.code == loop.robot.code for t in delivered)
                for loop in self.loops
            },
            wall=wall,
            heartbeats=self.heartbeats,
            charging_trips=BoardMessage.objects.filter(
                type="plan", body__stops__0__charge=True
            ).count(),
            lowest_battery=min(loop.robot.lowest_battery for loop in self.loops),
            priorities=[t.priority for t in delivered],
            on_time=[t.due_at is None or t.delivered_at <= t.due_at for t in delivered],
            eta_error=_eta_errors(self.first_eta, delivered),
            eta_error_loaded=_eta_errors(self.loaded_eta, delivered),
        )


def _note_new_etas(noted: dict, **wanted) -> None:
    """Add to `noted` (task pk -> ETA) the tasks with an ETA (and `wanted`) not noted yet."""
    from scheduling.models import Task

    fresh = Task.objects.filter(eta__isnull=False, **wanted).exclude(pk__in=list(noted))
    noted.update(fresh.values_list("pk", "eta"))


def _eta_errors(noted: dict, delivered) -> list[float]:
    """Seconds, the noted ETA minus the actual drop-off, per delivered task that has one."""
    return [(noted[t.pk] - t.delivered_at).total_seconds() for t in delivered if t.pk in noted]


def _staff_user():
    from django.contrib.auth import get_user_model

    user, _ = get_user_model().objects.get_or_create(
        username="hospital-systems", defaults={"is_staff": True}
    )
    return user


if __name__ == "__main__":
    sys.exit(main())
