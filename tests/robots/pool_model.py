"""A model of robots heartbeating to a pool of web workers, for the heartbeat cadence's tests
(robots/cadence.py): no clock, no sleep, no server.

`workers` workers take heartbeats first come, first served, the pool serving `capacity` a second
at most; each robot sends its next heartbeat the interval it was told after its answer, as the
protocol asks, the interval spread as the server spreads it
(robots.cadence.heartbeat_interval_spread). Windows are closed as core.busy closes them and
given to the controller: the requests served, the processor time they cost (more per request
the busier the pool, as measured on a 2-core machine), and the queue read at each request's
start.
"""

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime

from core.busy import WINDOW_SECONDS, Window
from robots.cadence import Controller, heartbeat_interval_spread

EPOCH = 1_800_000_000.0  # the model's second 0 on the wall clock, for the spread
COST = 0.005  # processor seconds a request costs with the pool idle; 20 % more saturated


@dataclass
class Answer:
    at: float  # seconds from the start
    waited: float  # from sending to the answer
    interval: float  # the interval the controller asked for (before the spread)


@dataclass
class Run:
    answers: list[Answer] = field(default_factory=list)
    flips: list[float] = field(default_factory=list)  # when robots came later than 3 told

    def rate(self, start: float, end: float) -> float:
        return sum(start <= a.at < end for a in self.answers) / (end - start)

    def waited(self, start: float, end: float, percent: float) -> float:
        waits = sorted(a.waited for a in self.answers if start <= a.at < end)
        return waits[min(int(percent / 100 * len(waits)), len(waits) - 1)]

    def intervals(self, start: float, end: float) -> set[float]:
        return {a.interval for a in self.answers if start <= a.at < end}


def run(
    controller: Controller,
    *,
    robots: int,
    capacity: float | Callable[[float], float],
    seconds: float,
    workers: int = 5,
    base: float = 1.0,
    first_cost: float = 1.0,
) -> Run:
    """`capacity`: heartbeats a second the pool serves, or a function of the time; a robot's
    first heartbeat costs `first_cost` times as much (a new boot's)."""
    capacity_at = capacity if callable(capacity) else (lambda _: capacity)
    due = [(n / robots, n) for n in range(robots)]  # sorted: phases over the first second
    free = [0.0] * workers
    seen: dict[int, tuple[float, float]] = {}  # robot -> (answered at, told)
    meter = _Meter(workers)
    result = Run()
    while due and due[0][0] < seconds:
        sent, robot = due.pop(0)
        worker = min(range(workers), key=free.__getitem__)
        start = max(sent, free[worker])
        cost = first_cost if robot not in seen else 1.0
        end = start + cost * workers / capacity_at(start)
        free[worker] = end
        waiting = bisect.bisect_right(due, (start, math.inf))  # sent already, not yet taken
        window = meter.request(start, end, waiting, cost)
        if window is not None:
            controller.judge(window, base=base, robots=robots)
        interval = max(controller.interval, base)
        told = heartbeat_interval_spread(robot, interval, base=base, now=_wall(start))
        if robot in seen and start - seen[robot][0] > 3 * seen[robot][1]:
            result.flips.append(start)
        seen[robot] = (start, told)
        result.answers.append(Answer(end, end - sent, interval))
        bisect.insort(due, (end + told, robot))
    return result


class _Meter:
    """Windows as core.busy closes them, for the whole pool."""

    def __init__(self, workers: int):
        self.workers = workers
        self.start: float | None = None
        self.served, self.cpu, self.waiting, self.least = 0, 0.0, 0, None

    def request(self, start, end, waiting, cost) -> Window | None:
        if self.start is None:
            self.start = start
        self.served += 1
        self.waiting += waiting
        self.least = waiting if self.least is None else min(self.least, waiting)
        busy = min(waiting / self.workers, 1.0)  # how near saturation the pool is
        self.cpu += cost * COST * (1 + 0.2 * busy)
        if end - self.start < WINDOW_SECONDS:
            return None
        window = Window(
            self.start,
            end,
            self.served,
            self.cpu,
            waiting=self.waiting / self.served,
            waiting_least=self.least,
            pool=self.workers,
        )
        self.start, self.served, self.cpu, self.waiting, self.least = end, 0, 0.0, 0, None
        return window


def _wall(second: float) -> datetime:
    return datetime.fromtimestamp(EPOCH + second, UTC)
