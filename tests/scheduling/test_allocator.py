"""The allocator against the paper's brute force on seeded random hospitals. No database."""

import math
import random
import subprocess
import sys
from collections import Counter
from dataclasses import replace
from pathlib import Path

import pytest

from bench.instances import Instance, building, many_to_one, one_to_many, one_to_one
from bench.instances import random_instance as generated
from scheduling import allocator
from scheduling.allocator import (
    EXACT_TASK_LIMIT,
    PICKUP,
    RobotRoute,
    added_cost_lower_bound,
    allocate,
    allocate_for_delivery_time,
    allocate_standby_first,
    best_plan,
    cheapest_insertion,
    enumerate_best_plan,
    route_cost,
)

ROOT = Path(__file__).resolve().parents[2]
MOST_STOPS = 9  # per robot, new task included: keeps the brute force to well under a second
SAME = 1e-9


def random_instance(seed, **options) -> Instance:
    """A generated instance, without robots too big for the brute force to check quickly."""
    instance = generated(seed, **options)
    small = [robot for robot in instance.robots if _stop_count(robot, instance.task) <= MOST_STOPS]
    return replace(instance, robots=tuple(small))


def _stop_count(robot, task) -> int:
    tasks = (*robot.tasks, task)
    return sum(len(each.pickups) + len(each.dropoffs) for each in tasks)


# (tasks held, instances, share of held tasks on board): several hundred in all.
SWEEP = [(0, 50, 0.4), (1, 70, 0.4), (2, 70, 0.4), (3, 50, 0.5), (4, 30, 0.7), (5, 25, 0.7)]


def _instances(held, count, on_board):
    for n in range(count):
        yield random_instance(
            held * 1000 + n,
            robots=3,
            held=held,
            capacity=(2, 4),  # tight, so capacity often decides the order
            on_board=on_board,
            multi_stop=0.35,
        )


def _brute_force_allocation(instance: Instance):
    """(added travel, robot) of least added travel by enumerating every ordering."""
    offers = []
    for robot in instance.robots:
        base = enumerate_best_plan(robot, instance.travel_time)
        plan = base and enumerate_best_plan(robot, instance.travel_time, extra=instance.task)
        if plan:
            offers.append((plan.cost - base.cost, robot.robot))
    return min(offers, default=None)


def assert_valid_route(robot: RobotRoute, plan, travel_time, *extra):
    """Every remaining stop once, drop-offs after their pick-ups, load within capacity."""
    expected = [stop for task in (*robot.tasks, *extra) for stop in task.pickups + task.dropoffs]
    assert Counter(plan.stops) == Counter(expected)
    waiting = Counter(stop.task for stop in plan.stops if stop.action == PICKUP)
    load = robot.load
    for stop in plan.stops:
        if stop.action == PICKUP:
            waiting[stop.task] -= 1
        else:
            assert waiting[stop.task] == 0, f"{stop} before its task's pick-ups"
        load += stop.load_change
        assert 0 <= load <= robot.capacity
    assert plan.cost == pytest.approx(route_cost(robot.start, plan.stops, travel_time), abs=SAME)


@pytest.mark.parametrize(("held", "count", "on_board"), SWEEP)
def test_it_finds_each_robots_optimal_route_as_enumeration_does(held, count, on_board):
    for instance in _instances(held, count, on_board):
        for robot in instance.robots:
            for extra in ((), (instance.task,)):
                ours = best_plan(robot, instance.travel_time, extra=extra[0] if extra else None)
                theirs = enumerate_best_plan(
                    robot, instance.travel_time, extra=extra[0] if extra else None
                )
                assert (ours is None) == (theirs is None)
                if ours:
                    assert ours.cost == pytest.approx(theirs.cost, abs=SAME)
                    assert ours.exact
                    assert_valid_route(robot, ours, instance.travel_time, *extra)


@pytest.mark.parametrize(("held", "count", "on_board"), SWEEP)
def test_it_allocates_to_a_robot_of_least_added_cost(held, count, on_board):
    for instance in _instances(held, count, on_board):
        wanted = _brute_force_allocation(instance)
        for metric in (True, False):
            got = allocate(instance.task, instance.robots, instance.travel_time, metric=metric)
            if wanted is None:
                assert got is None
                continue
            assert got.added_cost == pytest.approx(wanted[0], abs=1e-6)
            robot = next(robot for robot in instance.robots if robot.robot == got.robot)
            assert_valid_route(robot, got.plan, instance.travel_time, instance.task)
            assert got.plan.exact


def test_it_allocates_like_enumeration_across_a_larger_fleet():
    for seed in range(15):
        instance = random_instance(9000 + seed, robots=12, held=(0, 2), multi_stop=0.2)
        wanted = _brute_force_allocation(instance)
        got = allocate(instance.task, instance.robots, instance.travel_time)
        assert (got.added_cost, got.robot) == (pytest.approx(wanted[0], abs=1e-6), wanted[1])


def test_it_never_bounds_above_the_exact_added_cost():
    for seed in range(80):
        instance = generated(seed, robots=4, held=(0, 3), capacity=(2, 5), multi_stop=0.35)
        for robot in instance.robots:
            base = best_plan(robot, instance.travel_time)
            plan = base and best_plan(robot, instance.travel_time, extra=instance.task)
            if plan:
                bound = added_cost_lower_bound(instance.task, robot, instance.travel_time)
                assert bound <= plan.cost - base.cost + SAME


def test_it_plans_an_idle_robot_from_where_it_is():
    site = building(_rng(1))
    a, b, c, d = site.places[:4]
    idle = RobotRoute("R-01", start=a, load=0, capacity=4, tasks=())
    task = many_to_one("T-0001", [b, c], d)
    plan = best_plan(idle, site.travel_time, extra=task)
    cheapest = min(
        site.travel_time(a, first) + site.travel_time(first, second) + site.travel_time(second, d)
        for first, second in ((b, c), (c, b))
    )
    assert plan.cost == pytest.approx(cheapest, abs=SAME)
    assert best_plan(idle, site.travel_time).cost == 0
    assert allocate(task, [idle], site.travel_time).added_cost == pytest.approx(cheapest)


def test_it_only_drops_off_a_task_already_on_board():
    site = building(_rng(2))
    a, b, c, d, e = site.places[:5]
    on_board = one_to_many("T-0001", a, [b, c])
    on_board = replace(on_board, pickups=())
    robot = RobotRoute("R-01", start=d, load=2, capacity=2, tasks=(on_board,))
    task = one_to_one("T-0002", e, a)
    plan = allocate(task, [robot], site.travel_time).plan
    assert_valid_route(robot, plan, site.travel_time, task)
    assert plan.stops.index(task.pickups[0]) > plan.stops.index(on_board.dropoffs[0])


def test_it_skips_a_robot_too_small_for_the_task():
    site = building(_rng(3))
    a, b, c, d = site.places[:4]
    task = one_to_many("T-0001", a, [b, c, d])
    small = RobotRoute("R-01", start=a, load=0, capacity=2, tasks=())
    big = RobotRoute("R-02", start=site.places[-1], load=0, capacity=3, tasks=())
    assert allocate(task, [small, big], site.travel_time).robot == "R-02"
    assert allocate(task, [small], site.travel_time) is None


def test_it_unloads_before_picking_up_when_the_robot_is_full():
    site = building(_rng(4))
    a, b, c, d = site.places[:4]
    held = replace(one_to_many("T-0001", a, [b, c]), pickups=())
    full = RobotRoute("R-01", start=d, load=2, capacity=2, tasks=(held,))
    task = one_to_many("T-0002", d, [a, b])
    plan = allocate(task, [full], site.travel_time).plan
    assert set(plan.stops[:2]) == set(held.dropoffs)
    assert allocate(task, [replace(full, load=3)], site.travel_time) is None


def test_it_returns_none_without_robots():
    site = building(_rng(5))
    assert allocate(one_to_one("T-0001", *site.places[:2]), [], site.travel_time) is None


def test_it_breaks_ties_by_robot_code():
    site = building(_rng(6))
    a, b, c = site.places[:3]
    twins = [RobotRoute(code, start=a, load=0, capacity=2, tasks=()) for code in ("R-09", "R-03")]
    chosen = {allocate(one_to_one("T-0001", b, c), twins, site.travel_time).robot for _ in "xyz"}
    assert chosen == {"R-03"}


def test_it_skips_robots_that_cannot_reach_the_task():
    site = building(_rng(7))
    island = {"X-1", "X-2", "X-3"}

    def travel_time(a, b):
        if (a in island) != (b in island):
            return math.inf
        return 5.0 if a in island and a != b else site.travel_time(a, b) if a not in island else 0

    task = one_to_one("T-0001", "X-1", "X-2")
    near = RobotRoute("R-01", start=site.places[0], load=0, capacity=2, tasks=())
    marooned = RobotRoute("R-02", start="X-3", load=0, capacity=2, tasks=())
    got = allocate(task, [near, marooned], travel_time)
    assert (got.robot, got.added_cost) == ("R-02", 10.0)
    assert allocate(task, [near], travel_time) is None


@pytest.mark.parametrize("seed", range(6))
def test_it_plans_long_routes_by_heuristic_no_worse_than_cheapest_insertion(seed):
    instance = generated(seed, robots=2, held=EXACT_TASK_LIMIT + 1, capacity=(6, 8))
    for robot in instance.robots:
        base = best_plan(robot, instance.travel_time)
        plan = best_plan(robot, instance.travel_time, extra=instance.task)
        inserted = cheapest_insertion(robot, base.stops, instance.task, instance.travel_time)
        assert not plan.exact
        assert_valid_route(robot, plan, instance.travel_time, instance.task)
        assert plan.cost <= inserted.cost + SAME
    got = allocate(instance.task, instance.robots, instance.travel_time)
    assert not got.plan.exact
    assert math.isfinite(got.added_cost)


@pytest.mark.parametrize("seed", range(6))
def test_its_long_routes_cannot_be_shortened_by_moving_one_run_of_stops(seed):
    instance = generated(seed, robots=2, held=EXACT_TASK_LIMIT + 2, capacity=(6, 8))
    for robot in instance.robots:
        plan = best_plan(robot, instance.travel_time, extra=instance.task)
        stops = list(plan.stops)
        for length in (1, 2, 3):
            for i in range(len(stops) - length + 1):
                run, rest = stops[i : i + length], stops[:i] + stops[i + length :]
                for j in range(len(rest) + 1):
                    moved = rest[:j] + run + rest[j:]
                    if _feasible(robot, moved):
                        assert _route_cost(robot, moved, instance.travel_time) >= plan.cost - SAME


def _feasible(robot: RobotRoute, stops) -> bool:
    """Every drop-off after all its task's pick-ups; load within [0, capacity]."""
    load = robot.load
    for n, stop in enumerate(stops):
        later_pickups = [s for s in stops[n:] if s.action == PICKUP and s.task == stop.task]
        if stop.action != PICKUP and later_pickups:
            return False
        load += stop.load_change
        if not 0 <= load <= robot.capacity:
            return False
    return True


def _route_cost(robot: RobotRoute, stops, travel_time) -> float:
    places = [robot.start, *(stop.place for stop in stops)]
    return sum(travel_time(a, b) for a, b in zip(places, places[1:], strict=False))


def _on_a_line(a: str, b: str) -> float:
    """Places named by their position on a corridor, in seconds: "600" -> 600."""
    return abs(float(a) - float(b))


def _carrying_to(start: str, dropoff: str, code="R-01") -> RobotRoute:
    """A robot at `start` with one task on board, for `dropoff`."""
    held = replace(one_to_one("T-0001", start, dropoff), pickups=())
    return RobotRoute(code, start=start, load=1, capacity=4, tasks=(held,))


def test_by_delivery_time_an_idle_robot_nearby_takes_what_a_busy_one_would_reach_late():
    busy = _carrying_to("0", "1000")
    idle = RobotRoute("R-02", start="500", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "600", "700")

    assert allocate(task, [busy, idle], _on_a_line).robot == "R-01"  # on its way: adds nothing
    chosen = allocate_for_delivery_time(task, [busy, idle], _on_a_line)
    assert (chosen.robot, chosen.added_cost) == ("R-02", 200.0)  # delivered at 200 s, not 700 s


def test_by_delivery_time_a_busy_robot_still_takes_a_task_on_its_way():
    busy = _carrying_to("0", "1000")
    far = RobotRoute("R-02", start="5000", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "600", "700")

    chosen = allocate_for_delivery_time(task, [busy, far], _on_a_line)

    assert (chosen.robot, chosen.added_cost) == ("R-01", 0.0)
    assert [stop.place for stop in chosen.plan.stops] == ["600", "700", "1000"]


def test_by_delivery_time_it_counts_the_delay_to_the_tasks_a_robot_holds():
    # R-01's least-travel route with the task, 500 -> 600 -> 700 -> 0, adds 400 s of travel
    # (R-02 would add 450 s) and delivers the new task at 200 s, but its own at 900 s, not
    # 500 s. Counting that delay, R-02 is the better choice: 450 + 450 < 400 + 200 + 400.
    busy = _carrying_to("500", "0")
    idle = RobotRoute("R-02", start="950", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "600", "700")

    assert allocate(task, [busy, idle], _on_a_line).robot == "R-01"
    assert allocate_for_delivery_time(task, [busy, idle], _on_a_line).robot == "R-02"


def test_the_papers_rule_gives_a_task_to_a_standby_robot_even_when_a_busy_one_adds_nothing():
    busy = _carrying_to("0", "1000")
    near = RobotRoute("R-02", start="5000", load=0, capacity=4, tasks=())
    nearer = RobotRoute("R-03", start="900", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "600", "700")

    chosen = allocate_standby_first(task, [busy, near, nearer], _on_a_line)

    assert (chosen.robot, chosen.added_cost) == ("R-03", 400.0)  # the soonest at the pick-up


def test_the_papers_rule_adds_least_travel_when_no_robot_stands_by():
    busy = _carrying_to("0", "1000")
    other = _carrying_to("5000", "6000", code="R-02")
    task = one_to_one("T-0002", "600", "700")

    assert allocate_standby_first(task, [busy, other], _on_a_line).robot == "R-01"


def test_a_weighted_task_goes_ahead_of_held_stops_when_its_drop_off_gains_more_than_travel():
    # On board: a routine item for 10. New: a STAT task from 0 to -100 (weight 8). Least travel
    # drops at 10 first (120 s in all, the STAT drop-off at 120 s); STAT first costs 90 s more
    # travel (210 s) and drops it off at 100 s: 210 + 7 x 100 < 120 + 7 x 120.
    held = _carrying_to("0", "10")
    stat = replace(one_to_one("T-0002", "0", "-100"), weight=8.0)

    plan = best_plan(held, _on_a_line, extra=stat)

    assert [stop.task for stop in plan.stops] == ["T-0002", "T-0002", "T-0001"]
    assert plan.cost == 210.0


def test_a_routine_task_keeps_the_least_travel_route():
    held = _carrying_to("0", "10")
    routine = one_to_one("T-0002", "0", "-100")

    plan = best_plan(held, _on_a_line, extra=routine)

    assert plan.stops[-1].task == "T-0002"  # the held drop-off first: 120 s, not 210 s
    assert plan.cost == 120.0


def test_a_deadline_puts_a_routine_task_first_when_it_would_be_late_otherwise():
    held = _carrying_to("0", "10")
    due = replace(one_to_one("T-0002", "0", "-100"), due=60.0)  # late by 40 s rather than 60 s

    plan = best_plan(held, _on_a_line, extra=due)

    assert [stop.task for stop in plan.stops] == ["T-0002", "T-0002", "T-0001"]


def test_at_one_station_the_soonest_due_is_unloaded_first():
    # Two items on board for the same station: the same travel in either order, and a dwell
    # at each stop; the one due sooner comes off first, whichever order the search found.
    later, sooner = (
        replace(one_to_one(code, "0", "1000"), pickups=(), due=due)
        for code, due in (("T-0001", 1500.0), ("T-0002", 1100.0))
    )
    robot = RobotRoute("R-01", start="0", load=2, capacity=4, tasks=(later, sooner), dwell=20.0)

    plan = best_plan(robot, _on_a_line)

    assert [stop.task for stop in plan.stops] == ["T-0002", "T-0001"]
    assert plan.cost == 1000.0


def test_by_delivery_time_lateness_comes_first():
    # R-01 passes the task on its way and drops it off at 600 s, adding no travel; idle R-02
    # would add 400 s of travel and drop it off at 400 s. Due at 500 s, it is R-02's.
    busy = _carrying_to("0", "1000")
    idle = RobotRoute("R-02", start="200", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "500", "600")

    assert allocate_for_delivery_time(task, [busy, idle], _on_a_line).robot == "R-01"
    due = replace(task, due=500.0)
    assert allocate_for_delivery_time(due, [busy, idle], _on_a_line).robot == "R-02"


@pytest.mark.parametrize("seed", range(120))
def test_by_delivery_time_robots_skipped_unsolved_could_not_have_won(seed):
    # Against solving every robot: the same robot and route on random hospitals whose tasks
    # carry due times and priorities' weights, some robots late, some idle, some paced.
    rng = random.Random(seed)
    instance = random_instance(seed, robots=8, held=(0, 4), capacity=(3, 6), on_board=0.4)
    fleet = [_with_deadlines(rng, robot) for robot in instance.robots]
    task = replace(instance.task, **_deadline(rng))
    times = instance.travel_time

    pruned = allocate_for_delivery_time(task, fleet, times)
    every = allocator._by_delivery_time(task, fleet, times, 1.0, prune=False)

    assert (pruned and pruned.robot) == (every and every.robot)
    assert (pruned and pruned.plan) == (every and every.plan)


def _with_deadlines(rng: random.Random, robot: RobotRoute) -> RobotRoute:
    tasks = tuple(replace(task, **_deadline(rng)) for task in robot.tasks)
    pace, dwell = rng.choice([(1.0, 0.0), (0.5, 20.0), (1.6, 45.0)])
    return replace(robot, tasks=tasks, pace=pace, dwell=dwell)


def _deadline(rng: random.Random) -> dict:
    weight = rng.choice([1.0, 1.0, 1.0, 2.0, 8.0])
    due = rng.choice([math.inf, math.inf, rng.uniform(0, 600), rng.uniform(600, 3000)])
    return {"weight": weight, "due": due}


def test_by_delivery_time_the_nearest_robot_on_time_spares_solving_far_ones(monkeypatch):
    solved = set()
    route = allocator._route
    monkeypatch.setattr(
        allocator, "_route", lambda robot, *a, **k: solved.add(robot.robot) or route(robot, *a, **k)
    )
    near = RobotRoute("R-02", start="500", load=0, capacity=4, tasks=())
    far = _carrying_to("9000", "9500", code="R-01")
    task = one_to_one("T-0002", "600", "700")

    assert allocate_for_delivery_time(task, [far, near], _on_a_line).robot == "R-02"
    # R-02's offer: 200 s of travel, the task done at 200 s (400); R-01 is 8,400 s away.
    assert "R-01" not in solved


@pytest.mark.parametrize("rule", [allocate, allocate_for_delivery_time, allocate_standby_first])
def test_of_robots_alike_one_is_solved_for_all_and_the_smallest_code_wins(rule, monkeypatch):
    # A burst offers each task to every robot, most standing empty at a few docks: robots
    # whose routes are alike get the same offer, so one of them is solved for all.
    solved = set()
    plan = allocator._plan
    monkeypatch.setattr(
        allocator, "_plan", lambda robot, *a, **k: solved.add(robot.robot) or plan(robot, *a, **k)
    )
    alike = [RobotRoute(f"R-{n:02d}", start="500", load=0, capacity=4, tasks=()) for n in (9, 3, 7)]
    farther = RobotRoute("R-01", start="900", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "600", "700")

    assert rule(task, [*alike, farther], _on_a_line).robot == "R-03"
    assert solved <= {"R-03", "R-01", ""}  # "": a route solved without the task, by route


def test_a_route_solved_before_is_not_reused_with_other_travel_times():
    busy = _carrying_to("0", "1000")
    idle = RobotRoute("R-02", start="500", load=0, capacity=4, tasks=())
    task = one_to_one("T-0002", "600", "700")

    def slower(a: str, b: str) -> float:
        return 2 * _on_a_line(a, b)

    assert allocate_for_delivery_time(task, [busy, idle], slower).robot == "R-02"
    # Were R-01's route of 2,000 s without the task taken for the 1,000 s it is now, the task
    # would seem to save it 1,000 s and go to it.
    assert allocate_for_delivery_time(task, [busy, idle], _on_a_line).robot == "R-02"


def test_it_generates_metric_travel_times():
    site = building(_rng(8))
    places = site.places[::7]
    t = site.travel_time
    for a in places:
        assert t(a, a) == 0
        for b in places:
            assert t(a, b) == pytest.approx(t(b, a))
            assert all(t(a, c) <= t(a, b) + t(b, c) + SAME for c in places)


def test_it_generates_the_same_instance_from_the_same_seed():
    assert generated(11, robots=3, held=2) == generated(11, robots=3, held=2)


def test_it_imports_nothing_from_django():
    code = "import sys, scheduling.allocator; sys.exit(any('django' in m for m in sys.modules))"
    assert subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=False).returncode == 0


def _rng(seed):
    return random.Random(seed)


def _secure(task, secure=True):
    """The task as a secure delivery (or not): each item then needs a lockable compartment."""
    pickups = tuple(replace(stop, secure=secure) for stop in task.pickups)
    return replace(
        task,
        pickups=pickups,
        dropoffs=tuple(replace(stop, secure=secure) for stop in task.dropoffs),
    )


def test_it_gives_each_secure_item_a_lockable_compartment_of_its_own():
    site = building(_rng(11))
    a, b, c, d = site.places[:4]
    held = _secure(one_to_one("T-0001", a, b))
    robot = RobotRoute("R-01", start=c, load=0, capacity=2, tasks=(held,), lockable=1)
    task = _secure(one_to_one("T-0002", c, d))

    plan = allocate(task, [robot], site.travel_time).plan

    # Two compartments, one lockable: the two secure deliveries are never on board together,
    # though that would be shorter (the control: a second lockable compartment).
    assert _most_secure_on_board(plan) == 1
    assert plan == enumerate_best_plan(robot, site.travel_time, extra=task)
    roomier = allocate(task, [replace(robot, lockable=2)], site.travel_time).plan
    assert _most_secure_on_board(roomier) == 2
    assert roomier.cost < plan.cost


def _most_secure_on_board(plan, on_board=0) -> int:
    most = on_board
    for stop in plan.stops:
        on_board += stop.load_change if stop.secure else 0
        most = max(most, on_board)
    return most


def test_it_gives_no_secure_delivery_to_a_robot_without_a_lockable_compartment_free():
    site = building(_rng(12))
    a, b, c = site.places[:3]
    on_board = replace(_secure(one_to_one("T-0001", a, b)), pickups=())
    full = RobotRoute("R-01", a, 1, 4, (on_board,), lockable=1, secure_load=1)
    task = _secure(one_to_one("T-0002", a, c))
    plan = allocate(task, [full], site.travel_time).plan
    assert plan.stops.index(task.pickups[0]) > plan.stops.index(on_board.dropoffs[0])

    empty = RobotRoute("R-01", a, 0, 4, ())
    assert allocate(task, [empty], site.travel_time) is None  # no lockable compartment
    assert allocate(_secure(task, False), [empty], site.travel_time)
    two_items = _secure(one_to_many("T-0003", a, [b, c]))
    assert allocate(two_items, [replace(empty, lockable=1)], site.travel_time) is None
    assert allocate(two_items, [replace(empty, lockable=2)], site.travel_time)


def test_its_heuristic_routes_keep_secure_items_within_the_lockable_compartments():
    site = building(_rng(13))
    places = site.places
    held = tuple(
        _secure(one_to_one(f"T-{n:04d}", places[n], places[n + 1])) for n in range(EXACT_TASK_LIMIT)
    )
    robot = RobotRoute("R-01", places[0], 0, 4, held, lockable=1)
    task = _secure(one_to_one("T-0099", places[-1], places[-2]))

    plan = allocate(task, [robot], site.travel_time).plan

    assert not plan.exact
    assert_valid_route(robot, plan, site.travel_time, task)
    assert _most_secure_on_board(plan) == 1


def test_a_task_shaped_like_one_already_solved_for_a_robot_reuses_its_order_with_its_own_stops(
    monkeypatch,
):
    robot = _carrying_to("0", "1000")
    first, second = one_to_one("T-0002", "600", "700"), one_to_one("T-0003", "600", "700")
    solves = []
    held_karp = allocator._held_karp
    monkeypatch.setattr(allocator, "_ORDERS", {})
    monkeypatch.setattr(allocator, "_held_karp", lambda *a: solves.append(a) or held_karp(*a))

    planned = best_plan(robot, _on_a_line, extra=first)
    solved = len(solves)
    again = best_plan(robot, _on_a_line, extra=second)

    assert len(solves) == solved  # the same places and loads: looked up, not solved again
    assert again.cost == planned.cost
    assert [(s.task, s.place) for s in again.stops] == [
        ("T-0003", "600"),
        ("T-0003", "700"),
        ("T-0001", "1000"),
    ]
    other = best_plan(robot, _on_a_line, extra=one_to_one("T-0004", "600", "1700"))
    assert len(solves) > solved  # another drop-off: another problem, solved
    assert [s.place for s in other.stops] == ["600", "1000", "1700"]


def _along_the_corridor(held: int) -> RobotRoute:
    """A robot at "0" holding `held` tasks up the corridor, none picked up yet."""
    tasks = tuple(
        one_to_one(f"T-{n:04d}", str(100 * n), str(100 * n + 50)) for n in range(1, held + 1)
    )
    return RobotRoute("R-01", start="0", load=0, capacity=2, tasks=tasks)


def _counted(monkeypatch, name: str) -> list:
    calls, real = [], getattr(allocator, name)
    monkeypatch.setattr(allocator, name, lambda *a, **k: calls.append(a) or real(*a, **k))
    return calls


def test_a_route_bounded_below_its_least_travel_is_refused_remembered_and_solved_when_allowed(
    monkeypatch,
):
    # An offer that could only win under a cost is solved with that bound; a robot that cannot
    # is refused, and remembered so that a lower bound later is refused without a solve.
    monkeypatch.setattr(allocator, "_ORDERS", {})
    monkeypatch.setattr(allocator, "_FINISHING", {})
    robot, task = _along_the_corridor(4), one_to_one("T-0009", "1000", "20")
    tasks, travel = (*robot.tasks, task), allocator._Travel(_on_a_line)
    least = enumerate_best_plan(robot, _on_a_line, extra=task).cost
    solves = _counted(monkeypatch, "_held_karp")

    assert allocator._plan(robot, tasks, travel, limit=least - 1.0) is None
    solved = len(solves)
    assert allocator._plan(robot, tasks, travel, limit=least - 5.0) is None
    assert len(solves) == solved  # known to cost more: not solved again
    plan = allocator._plan(robot, tasks, travel, limit=least + 1.0)
    assert len(solves) == solved + 1
    assert plan.exact
    assert plan.cost == pytest.approx(least, abs=SAME)
    assert_valid_route(robot, plan, _on_a_line, task)


def test_a_route_beyond_the_exact_limit_takes_a_new_task_into_its_kept_route(monkeypatch):
    # The held route of EXACT_TASK_LIMIT + 2 tasks is built once (insertion after the exact
    # first ones); each offer then inserts the new task into it, not every task past the limit.
    monkeypatch.setattr(allocator, "_ORDERS", {})
    robot = _along_the_corridor(EXACT_TASK_LIMIT + 2)
    insertions = _counted(monkeypatch, "_inserted")
    held = best_plan(robot, _on_a_line)

    for n, place in enumerate(("250", "650", "900")):
        task = one_to_one(f"T-01{n:02d}", place, "30")
        before = len(insertions)
        plan = best_plan(robot, _on_a_line, extra=task)
        assert len(insertions) == before + 1
        assert not plan.exact
        assert plan.cost >= held.cost
        assert_valid_route(robot, plan, _on_a_line, task)
