"""Benchmark the allocator against the paper's brute force, and against plain cheapest insertion.

    python bench/allocation.py            # 10 and 50 robots holding 1..5 tasks each (minutes)
    python bench/allocation.py --quick    # small counts, seconds: what CI runs
    python bench/allocation.py --burst    # only the last table: a burst, allocator alone
    python bench/allocation.py --rule     # only the default rule's table (delivery_time)

For each fleet size and tasks held: the median and 90th-percentile time of allocate(); the
median time of enumerating every ordering for every robot (the paper, Sec. 3.1.2) on some of
the same instances, capped at ENUMERATION_CAP seconds an instance; whether both found the same
least added travel; and how often cheapest insertion into each robot's optimal route picks a
costlier robot, and how much longer than optimal the route it builds is.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import math
import os
import platform
import random
import statistics
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving
from bench.instances import Instance, building, one_to_one, random_instance
from scheduling.allocator import (
    TOLERANCE,
    Allocation,
    RobotRoute,
    allocate,
    allocate_for_delivery_time,
    best_plan,
    cheapest_insertion,
    enumerate_best_plan,
)

ENUMERATION_CAP = 60.0  # seconds for one instance before the brute force is given up
AGREEMENT = 1e-6  # seconds between our least added travel and the brute force's


@dataclass(frozen=True)
class Settings:
    robots: tuple[int, ...]
    held: tuple[int, ...]
    instances: int
    enumerated: dict[int, int]  # tasks held -> instances also solved by brute force
    mixed_robots: int  # fleet size of the second table (mixed task kinds, no brute force)
    burst: int  # tasks at once and robots of the last table
    bursts: int  # seeded bursts


FULL = Settings((10, 50), (1, 2, 3, 4, 5), 20, {1: 20, 2: 20, 3: 20, 4: 10, 5: 3}, 50, 100, 5)
QUICK = Settings((3, 10), (1, 2, 3), 3, {1: 3, 2: 3, 3: 3}, 10, 20, 2)
BURST_CAPACITY = 4  # items a robot of the burst carries at once


@dataclass
class Row:
    robots: int
    held: int
    ours: list[float] = field(default_factory=list)  # seconds, every instance
    ours_enumerated: list[float] = field(default_factory=list)  # seconds, where both ran
    enumeration: list[float] = field(default_factory=list)
    timed_out: bool = False
    agreed: int = 0
    costlier_robot: int = 0  # cheapest insertion chose a robot that adds more travel
    route_excess: list[float] = field(default_factory=list)  # its route / optimal route - 1


@saving.saves("allocation")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small counts, for CI")
    parser.add_argument("--burst", action="store_true", help="only the burst table")
    parser.add_argument("--rule", action="store_true", help="only the default rule's table")
    saving.add_argument(parser)
    options = parser.parse_args(argv)
    settings = QUICK if options.quick else FULL
    _print_header(settings, one_table=options.burst or options.rule)
    if options.burst:
        _print_burst(settings)
        return 0
    if options.rule:
        _print_default_rule(settings)
        return 0
    rows = _compare(settings)
    _print_table(rows)
    _print_mixed(settings)
    _print_default_rule(settings)
    compared = sum(len(row.enumeration) for row in rows)
    agreed = sum(row.agreed for row in rows)
    _print_burst(settings)
    print(f"\nagreement with enumeration: {agreed}/{compared} instances")
    return 0 if agreed == compared else 1


def _print_header(settings: Settings, *, one_table: bool = False) -> None:
    now = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    print(f"allocation benchmark  {now}")
    print(f"Python {platform.python_version()} ({platform.python_implementation()})")
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.platform()}")
    if one_table:
        return
    print(
        f"{settings.instances} seeded instances per row: a 4-floor building with lifts; "
        "one-to-one tasks, 40 % of held tasks already picked up; capacity 4-6."
    )
    print(f"enumeration capped at {ENUMERATION_CAP:.0f} s an instance; insertion is into each")
    print("robot's optimal route, pick-ups and drop-offs inserted where they add least.\n")


def _compare(settings: Settings) -> list[Row]:
    rows = []
    for robots in settings.robots:
        enumerating = True
        for held in settings.held:
            row = _row(robots, held, settings, enumerating=enumerating)
            enumerating = not row.timed_out
            rows.append(row)
    return rows


def _row(robots: int, held: int, settings: Settings, *, enumerating: bool) -> Row:
    row = Row(robots, held)
    for n in range(settings.instances):
        instance = _instance(robots, held, n)
        ours, seconds = _timed(_allocate, instance)
        row.ours.append(seconds)
        _compare_insertion(row, instance, ours)
        if enumerating and n < settings.enumerated.get(held, 0):
            enumerating = _compare_enumeration(row, instance, ours, seconds)
    return row


def _instance(robots: int, held: int, n: int) -> Instance:
    return random_instance(_seed(robots, held, n), robots=robots, held=held, multi_stop=0)


def _seed(robots: int, held: int, n: int) -> int:
    return robots * 10_000 + held * 1_000 + n


def _timed(function, *args):
    gc.collect()  # so that garbage from building the instance is not collected on our clock
    started = time.perf_counter()
    result = function(*args)
    return result, time.perf_counter() - started


def _allocate(instance: Instance) -> Allocation | None:
    return allocate(instance.task, instance.robots, instance.travel_time)


def _compare_enumeration(row: Row, instance: Instance, ours, our_seconds: float) -> bool:
    """Adds the brute force's time and agreement to the row; False once it passes the cap."""
    deadline = time.perf_counter() + ENUMERATION_CAP
    try:
        theirs, seconds = _timed(_enumerate, instance, deadline)
    except TimeoutError:
        row.timed_out = True
        return False
    row.enumeration.append(seconds)
    row.ours_enumerated.append(our_seconds)
    row.agreed += _same_optimum(ours, theirs)
    return True


def _enumerate(instance: Instance, deadline: float) -> tuple[float, str] | None:
    """The paper's method: the least (added travel, robot) over all robots, by brute force."""
    offers = []
    for robot in instance.robots:
        base = enumerate_best_plan(robot, instance.travel_time, deadline=deadline)
        plan = base and enumerate_best_plan(
            robot, instance.travel_time, extra=instance.task, deadline=deadline
        )
        if plan:
            offers.append((plan.cost - base.cost, robot.robot))
    return min(offers, default=None)


def _same_optimum(ours: Allocation | None, theirs: tuple[float, str] | None) -> bool:
    if ours is None or theirs is None:
        return ours is None and theirs is None
    return abs(ours.added_cost - theirs[0]) <= AGREEMENT


def _compare_insertion(row: Row, instance: Instance, ours: Allocation | None) -> None:
    """How cheapest insertion into each robot's optimal route would have done."""
    chosen = _insertion_choice(instance)
    if ours is None or chosen is None:
        return
    robot, inserted = chosen
    best = best_plan(robot, instance.travel_time, extra=instance.task)
    base = best_plan(robot, instance.travel_time)
    row.costlier_robot += best.cost - base.cost > ours.added_cost + AGREEMENT
    row.route_excess.append(inserted.cost / best.cost - 1 if best.cost else 0.0)


def _insertion_choice(instance: Instance):
    offers = []
    for robot in instance.robots:
        base = best_plan(robot, instance.travel_time)
        plan = base and cheapest_insertion(robot, base.stops, instance.task, instance.travel_time)
        if plan:
            offers.append((plan.cost - base.cost, robot.robot, robot, plan))
    if not offers:
        return None
    least = min(added for added, *_ in offers)
    _, _, robot, plan = min(offer for offer in offers if offer[0] <= least + TOLERANCE)[:4]
    return robot, plan


def _print_table(rows: list[Row]) -> None:
    print(
        f"{'robots':>6} {'k':>2} {'ours med':>9} {'ours p90':>9} {'enum med':>9} "
        f"{'speed-up':>9} {'agree':>6}   {'insertion: costlier robot, route excess mean/max':<}"
    )
    for row in rows:
        print(
            f"{row.robots:>6} {row.held:>2} {_ms(statistics.median(row.ours)):>9} "
            f"{_ms(_p90(row.ours)):>9} {_enumeration_median(row):>9} {_speed_up(row):>9} "
            f"{_agreement(row):>6}   {_insertion_summary(row)}"
        )


def _print_mixed(settings: Settings) -> None:
    """Ours alone on mixed task kinds, where brute force is hopeless beyond a few tasks."""
    print(
        f"\nmixed tasks (30 % one-to-many or many-to-one, 2-3 items), {settings.mixed_robots} "
        "robots, ours only:"
    )
    print(f"{'k':>2} {'ours med':>9} {'ours p90':>9} {'ours max':>9}")
    for held in settings.held:
        seconds = [
            _timed(_allocate, _mixed_instance(settings.mixed_robots, held, n))[1]
            for n in range(settings.instances)
        ]
        print(
            f"{held:>2} {_ms(statistics.median(seconds)):>9} {_ms(_p90(seconds)):>9} "
            f"{_ms(max(seconds)):>9}"
        )


def _print_default_rule(settings: Settings) -> None:
    """The default rule (delivery_time) on the first table's instances. It weighs lateness and
    waiting, not travel alone, so it solves more of the robots' routes than allocate() does."""
    print("\nthe default rule (delivery_time) on the same instances, ours only:")
    print(f"{'robots':>6} {'k':>2} {'ours med':>9} {'ours p90':>9}")
    for robots in settings.robots:
        for held in settings.held:
            seconds = [
                _timed(_allocate_by_delivery_time, _instance(robots, held, n))[1]
                for n in range(settings.instances)
            ]
            median, p90 = statistics.median(seconds), _p90(seconds)
            print(f"{robots:>6} {held:>2} {_ms(median):>9} {_ms(p90):>9}")


def _allocate_by_delivery_time(instance: Instance) -> Allocation | None:
    return allocate_for_delivery_time(instance.task, instance.robots, instance.travel_time)


def _print_burst(settings: Settings) -> None:
    count = settings.burst
    print(
        f"\na burst: {count} tasks at once, {count} robots empty at 4 docks (capacity "
        f"{BURST_CAPACITY}), delivery_time, each task added to its robot's route; CPU ms:"
    )
    print(
        f"{'seed':>4} {'total':>8} {'per task':>9} {'p90':>7} {'max':>7} {'robots':>7} {'most':>5}"
    )
    for seed in range(settings.bursts):
        spent, routes = _burst(seed, count)
        busy = [len(route.tasks) for route in routes if route.tasks]
        print(
            f"{seed:>4} {sum(spent) * 1000:>8.0f} {statistics.mean(spent) * 1000:>9.2f} "
            f"{_p90(spent) * 1000:>7.2f} {max(spent) * 1000:>7.2f} {len(busy):>7} {max(busy):>5}"
        )


def _burst(seed: int, count: int) -> tuple[list[float], list[RobotRoute]]:
    """The CPU seconds of each task's allocation, and the robots' routes at the end."""
    rng = random.Random(f"burst-{seed}")
    site = building(rng)
    docks, stations = rng.sample(site.places, 4), rng.sample(site.places, 6)
    empty = [RobotRoute(f"R-{n:03d}", docks[n % 4], 0, BURST_CAPACITY, ()) for n in range(count)]
    robots = {route.robot: route for route in empty}
    spent = []
    for n in range(count):
        task = one_to_one(f"T-{n:04d}", *rng.sample(stations, 2))
        started = time.process_time()
        chosen = allocate_for_delivery_time(task, list(robots.values()), site.travel_time)
        spent.append(time.process_time() - started)
        route = robots[chosen.robot]
        robots[chosen.robot] = replace(route, tasks=(*route.tasks, task))
    return spent, list(robots.values())


def _mixed_instance(robots: int, held: int, n: int) -> Instance:
    return random_instance(_seed(robots, held, n) + 500, robots=robots, held=held, multi_stop=0.3)


def _ms(seconds: float) -> str:
    return f"{seconds * 1000:.2f}ms"


def _p90(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[math.ceil(0.9 * len(ordered)) - 1]


def _enumeration_median(row: Row) -> str:
    if row.timed_out and not row.enumeration:
        return f">{ENUMERATION_CAP:.0f} s"
    if not row.enumeration:
        return "-"
    median = statistics.median(row.enumeration)
    return f"{median:.2f}s" if median >= 1 else _ms(median)


def _speed_up(row: Row) -> str:
    if not row.enumeration:
        return "-"
    ratio = statistics.median(row.enumeration) / statistics.median(row.ours_enumerated)
    return f"{ratio:.0f}x" if ratio >= 10 else f"{ratio:.1f}x"


def _agreement(row: Row) -> str:
    return f"{row.agreed}/{len(row.enumeration)}" if row.enumeration else "-"


def _insertion_summary(row: Row) -> str:
    if not row.route_excess:
        return "-"
    share = row.costlier_robot / len(row.route_excess)
    mean, most = statistics.mean(row.route_excess), max(row.route_excess)
    return f"{share:4.0%} of {len(row.route_excess)}, {mean:5.1%} / {most:5.1%}"


if __name__ == "__main__":
    sys.exit(main())
