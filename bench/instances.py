"""Seeded random fleets in a hospital-like building, shared by the allocator's tests and benchmark.

Travel time within a floor is walking distance over speed; between floors it is a walk to a lift,
a fixed wait, a ride per floor and a walk from the lift, through whichever lift is quickest. That
makes every time the length of a shortest path, so the triangle inequality holds, as it does for
shortest paths in a real building graph.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

from scheduling.allocator import DROPOFF, PICKUP, RobotRoute, Stop, TaskStops

FLOOR_WIDTH, FLOOR_DEPTH = 120.0, 40.0  # metres
LIFTS = ((30.0, 20.0), (90.0, 20.0))  # the same shafts on every floor
WALK_SPEED = 1.0  # metres per second
LIFT_WAIT = 30.0  # seconds from calling a lift to leaving in it
LIFT_SECONDS_PER_FLOOR = 4.0


@dataclass(frozen=True)
class Building:
    times: dict[str, dict[str, float]]

    @property
    def places(self) -> list[str]:
        return list(self.times)

    def travel_time(self, a: str, b: str) -> float:
        return self.times[a][b]


@dataclass(frozen=True)
class Instance:
    building: Building
    robots: tuple[RobotRoute, ...]
    task: TaskStops

    @property
    def travel_time(self):
        return self.building.travel_time


def building(rng: random.Random, *, floors: int = 4, per_floor: int = 25) -> Building:
    waypoints = {
        f"F{floor}-W{n:02d}": (floor, rng.uniform(0, FLOOR_WIDTH), rng.uniform(0, FLOOR_DEPTH))
        for floor in range(floors)
        for n in range(per_floor)
    }
    times = {a: {b: _seconds(waypoints[a], waypoints[b]) for b in waypoints} for a in waypoints}
    return Building(times)


def _seconds(a: tuple[int, float, float], b: tuple[int, float, float]) -> float:
    (floor_a, *xy_a), (floor_b, *xy_b) = a, b
    if floor_a == floor_b:
        return math.dist(xy_a, xy_b) / WALK_SPEED
    ride = LIFT_WAIT + LIFT_SECONDS_PER_FLOOR * abs(floor_a - floor_b)
    return (
        min((math.dist(xy_a, lift) + math.dist(lift, xy_b)) / WALK_SPEED for lift in LIFTS) + ride
    )


def random_instance(
    seed: int,
    *,
    robots: int,
    held: int | tuple[int, int],
    capacity: tuple[int, int] = (4, 6),
    on_board: float = 0.4,
    multi_stop: float = 0.3,
) -> Instance:
    """`robots` robots each holding `held` tasks (or a random count in that range) and a new task.

    A share `on_board` of held tasks are picked up already, a share `multi_stop` are one-to-many
    or many-to-one with 2 or 3 items; capacities are drawn from `capacity` and raised to what the
    robot already carries.
    """
    rng = random.Random(seed)
    site = building(rng)
    codes = iter(range(1, 10**6))
    fleet = tuple(
        _robot(rng, site, f"R-{n:02d}", _count(rng, held), capacity, on_board, multi_stop, codes)
        for n in range(1, robots + 1)
    )
    task = random_task(rng, site, f"T-{next(codes):04d}", multi_stop=multi_stop)
    return Instance(site, fleet, task)


def _count(rng: random.Random, held: int | tuple[int, int]) -> int:
    return held if isinstance(held, int) else rng.randint(*held)


def _robot(rng, site, code, held, capacity, on_board, multi_stop, codes) -> RobotRoute:
    tasks, load = [], 0
    for _ in range(held):
        task = random_task(rng, site, f"T-{next(codes):04d}", multi_stop=multi_stop)
        if rng.random() < on_board:
            task = _partly_done(rng, task)
        load += _on_board(task)
        tasks.append(task)
    biggest = max((_items(task) for task in tasks), default=0)
    limit = max(rng.randint(*capacity), load, biggest)
    return RobotRoute(code, rng.choice(site.places), load, limit, tuple(tasks))


def random_task(
    rng: random.Random, site: Building, code: str, *, multi_stop: float = 0.3
) -> TaskStops:
    """One-to-one, or with probability `multi_stop` one-to-many or many-to-one."""
    if rng.random() >= multi_stop:
        return one_to_one(code, *rng.sample(site.places, 2))
    places = rng.sample(site.places, 1 + rng.randint(2, 3))
    if rng.random() < 0.5:
        return one_to_many(code, places[0], places[1:])
    return many_to_one(code, places[:-1], places[-1])


def one_to_one(code: str, pickup: str, dropoff: str) -> TaskStops:
    return one_to_many(code, pickup, [dropoff])


def one_to_many(code: str, pickup: str, dropoffs: list[str]) -> TaskStops:
    first = Stop(code, 0, pickup, PICKUP, len(dropoffs))
    rest = tuple(Stop(code, i, place, DROPOFF, -1) for i, place in enumerate(dropoffs, 1))
    return TaskStops(code, (first,), rest)


def many_to_one(code: str, pickups: list[str], dropoff: str) -> TaskStops:
    firsts = tuple(Stop(code, i, place, PICKUP, 1) for i, place in enumerate(pickups))
    last = Stop(code, len(pickups), dropoff, DROPOFF, -len(pickups))
    return TaskStops(code, firsts, (last,))


def _partly_done(rng: random.Random, task: TaskStops) -> TaskStops:
    """The task with its pick-ups done (and maybe some drop-offs), or some of its pick-ups."""
    if len(task.pickups) > 1 and rng.random() < 0.5:
        return TaskStops(
            task.code, task.pickups[rng.randint(1, len(task.pickups) - 1) :], task.dropoffs
        )
    return TaskStops(task.code, (), task.dropoffs[rng.randint(0, len(task.dropoffs) - 1) :])


def _on_board(task: TaskStops) -> int:
    """Items of the task the robot carries now: what its drop-offs unload minus pick-ups to come."""
    unloaded = -sum(stop.load_change for stop in task.dropoffs)
    return unloaded - sum(stop.load_change for stop in task.pickups)


def _items(task: TaskStops) -> int:
    return -sum(stop.load_change for stop in task.dropoffs)
