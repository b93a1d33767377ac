"""Choose the robot that takes a new delivery task, and the order it then visits its stops in.

The paper's scheduler (Sec. 3.1.2) costs every ordering of every robot's stops. Here a robot's
route is solved exactly by dynamic programming over (stops done, last stop): Held-Karp where
precedence and capacity decide which stops may come next. Offering a task to a robot solves its
route without the task backwards, which gives the exact least travel left from every state, then
solves the route with the task forwards, dropping every state that cannot beat the best offer so
far (or, before there is one, the task inserted into the held route). Across robots, a cheap
lower bound on each robot's added travel skips robots that cannot win. Routes of more than
EXACT_TASK_LIMIT tasks are planned by insertion and local search instead and are marked inexact.

Deadlines: a task may carry a due time and a weight (its priority). A route is then chosen by
its weighted lateness first, then its travel plus the extra weight of the hurried tasks' drop-off
times, among its least-travel route and, for each hurried task (weighted above 1, or late in
that route), its least-travel route doing that task first (precedence and capacity still hold).
A route of unweighted tasks on time is its exact least-travel route, as before.

Pure: standard library only, so it can be tested and benchmarked without Django.
"""

from __future__ import annotations

import math
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, fields, replace
from functools import cached_property, lru_cache
from operator import sub

EXACT_TASK_LIMIT = 6  # tasks in one route (held + new) that are still solved exactly
TOLERANCE = 1e-9  # seconds; costs closer than this are treated as equal
PICKUP = "pickup"
DROPOFF = "dropoff"

TravelTime = Callable[[str, str], float]


@dataclass(frozen=True)
class Stop:
    task: str
    index: int
    place: str
    action: str
    load_change: int
    secure: bool = False  # a secure delivery's: each of its items needs a lockable compartment


@dataclass(frozen=True)
class TaskStops:
    """The stops of one task that remain to be done (done stops are left out); `due` is the
    seconds from now by which its last drop-off must be done, `weight` its priority's."""

    code: str
    pickups: tuple[Stop, ...]
    dropoffs: tuple[Stop, ...]
    due: float = math.inf
    weight: float = 1.0

    @cached_property
    def shape(self) -> tuple:
        """Its stops' places and load changes, without its code (_shape); kept, as a batch
        looks a route's orders up for task after task."""
        return _stops_shape(self.pickups), _stops_shape(self.dropoffs)


@dataclass(frozen=True)
class RobotRoute:
    robot: str
    start: str
    load: int
    capacity: int
    tasks: tuple[TaskStops, ...]
    dwell: float = 0.0  # seconds spent at each stop (loading, unloading)
    pace: float = 1.0  # its travel times over travel_time's, for when tasks are done
    lockable: int = 0  # lockable compartments: secure items on board at once, at most
    secure_load: int = 0  # secure items on board now (counted in `load` too)
    wear: int = 0  # tasks given so far: of equally good robots, the least worn wins (_rank)

    @cached_property
    def nameless(self) -> RobotRoute:
        """The route without the robot's code and wear: robots alike share it (_distinct,
        _held_plan). Kept, with its hash, as a batch offers each of its tasks to the same routes
        again."""
        values = {field.name: getattr(self, field.name) for field in fields(self)}
        return _NamelessRoute(**{**values, "robot": "", "wear": 0})


class _NamelessRoute(RobotRoute):
    """A RobotRoute whose hash is computed once (a tuple of tasks of stops: costly to hash)."""

    @cached_property
    def _hash(self) -> int:
        return super().__hash__()

    def __hash__(self) -> int:
        return self._hash


@dataclass(frozen=True)
class Plan:
    stops: tuple[Stop, ...]
    cost: float
    exact: bool


@dataclass(frozen=True)
class Allocation:
    robot: str
    plan: Plan
    added_cost: float


def best_plan(
    robot: RobotRoute, travel_time: TravelTime, *, extra: TaskStops | None = None
) -> Plan | None:
    """The cheapest order of the robot's remaining stops (and extra's); None if none is feasible.

    Exact up to EXACT_TASK_LIMIT tasks, otherwise the result of insertion and local search;
    with deadlines, the route the module docstring describes.
    """
    return _route(robot, robot.tasks + ((extra,) if extra else ()), _Travel(travel_time))


def allocate(
    task: TaskStops,
    robots: Sequence[RobotRoute],
    travel_time: TravelTime,
    *,
    metric: bool = True,
) -> Allocation | None:
    """The robot, and its new route, whose route grows least by taking `task`.

    With metric travel times (shortest paths obey the triangle inequality) lower bounds prune
    the search; pass metric=False for times that may not. Ties go to the robot given fewer
    tasks, then to the smallest code (_rank).
    """
    travel, robots = _Travel(travel_time), _distinct(robots)
    rank = {robot.robot: _rank(robot) for robot in robots}
    bounds = [_lower_bound(task, robot, travel) if metric else 0.0 for robot in robots]
    metric = metric and not travel.saw_infinity
    best = None
    for i in sorted(range(len(robots)), key=lambda i: (bounds[i], rank[robots[i].robot])):
        robot = robots[i]
        if metric and best and bounds[i] > best.added_cost + TOLERANCE:
            break
        margin = best.added_cost if best else math.inf
        offer = _offer(task, robot, travel, margin=margin, metric=metric)
        if offer and _is_better(offer, best, rank):
            best = offer
    return best


def allocate_for_delivery_time(
    task: TaskStops,
    robots: Sequence[RobotRoute],
    travel_time: TravelTime,
    *,
    waiting_weight: float = 1.0,
) -> Allocation | None:
    """Like allocate, but the robot is chosen by the lateness it causes first, then by added
    travel plus the waiting it causes.

    `allocate` gives a task to the robot whose route it lengthens least. A robot already out on
    a long route is nearly always that robot, so it collects task after task while the others
    stay at their docks, and deliveries wait (bench/fleet_day.py). Here each robot's route with
    the task is its best route (`best_plan`), and the robot is the one minimising first

        the weighted lateness the task adds (its own, and how much later held tasks are late)

    and, among robots adding the same (to the second), the least

        added travel + waiting_weight * (the new task's weighted time to its last drop-off
                                         + the weighted delay it adds to the held tasks)

    so a busy robot still takes a task on its way, an idle one takes a task a busy robot would
    only reach late, and a STAT task takes the robot that drops it off in time. `added_cost` of
    the result is the added travel alone. Robots are tried nearest the task first; a robot
    whose route is on time and least-travel is skipped when even the new task's own waiting
    (from reaching its farthest stop, `_earliest_done`) is more than the best offer's second
    part while that one is on time: such a robot can add no lateness, and no negative travel
    or delay. Ties go to the robot given fewer tasks, then to the smallest code (_rank).
    """
    return _by_delivery_time(task, robots, travel_time, waiting_weight, prune=True)


def _by_delivery_time(task, robots, travel_time, waiting_weight: float, *, prune: bool):
    travel = _Travel(travel_time)
    best = None  # ((weighted lateness, travel + waiting), Allocation)
    robots = _distinct(robots)
    rank = {robot.robot: _rank(robot) for robot in robots}
    nearest = {robot.robot: _earliest_done(task, robot, travel) for robot in robots}
    for robot in sorted(robots, key=lambda robot: (nearest[robot.robot], rank[robot.robot])):
        base = _held_plan(robot.nameless, travel_time)
        if not base:
            continue
        least = waiting_weight * task.weight * nearest[robot.robot]
        limit = _winning_cost(best[0], least, robot, base, travel) if prune and best else math.inf
        if limit < base.cost:
            continue
        plan = _route(robot, (*robot.tasks, task), travel, limit=limit)
        if not plan or not math.isfinite(plan.cost):
            continue
        late, waiting = _delays(robot, base, plan, (*robot.tasks, task), task.code, travel)
        key = (math.floor(late), plan.cost - base.cost + waiting_weight * waiting)
        if best is None or _before(key, rank[robot.robot], *best, rank):
            best = (key, Allocation(robot.robot, plan, plan.cost - base.cost))
    return best and best[1]


def _before(
    key: tuple[int, float], ranked, best: tuple[int, float], held: Allocation, rank
) -> bool:
    """Whether an offer with `key` from a robot ranked `ranked` beats the best so far (ties:
    _rank)."""
    if key[0] != best[0]:
        return key[0] < best[0]
    if abs(key[1] - best[1]) > TOLERANCE:
        return key[1] < best[1]
    return ranked < rank[held.robot]


def _earliest_done(task: TaskStops, robot: RobotRoute, travel: _Travel) -> float:
    """A lower bound on when the robot can be done with the task: it reaches the task's farthest
    stop no sooner than straight there (metric travel times), and stops at each of them."""
    stops = (*task.pickups, *task.dropoffs)
    farthest = max((travel[robot.start][stop.place] for stop in stops), default=0.0)
    return robot.pace * farthest + robot.dwell * len(stops)


def _winning_cost(best: tuple[int, float], least: float, robot, base: Plan, travel) -> float:
    """The most the robot's least-travel route with the task may cost for its offer to beat
    `best` (-inf: it cannot; inf: no bound known).

    When its held route is exact, least-travel and on time, the task adds no negative travel,
    delay or lateness: if the best offer takes lateness away, this one loses; if it adds none,
    this one wins only with added travel + waiting within the best's, and its waiting is at
    least `least`, the new task's own least weighted waiting with this robot. Any route the
    robot may choose costs at least its least-travel one.
    """
    if best[0] > 0 or len(robot.tasks) + 1 > EXACT_TASK_LIMIT:
        return math.inf
    if any(t.weight > 1.0 for t in robot.tasks):  # its route may be hurried, not least-travel
        return math.inf
    done = _done_at(robot, base, travel)
    if any(done.get(t.code, 0.0) > t.due for t in robot.tasks):  # late: it may be hurried
        return math.inf
    if best[0] < 0 or least > best[1] + TOLERANCE:
        return -math.inf
    return base.cost + best[1] - least + TOLERANCE


def _delays(robot, base: Plan, plan: Plan, tasks, new: str, travel: _Travel):
    """(weighted lateness added, weighted waiting) of going from `base` to `plan`: the new
    task's lateness and time to its drop-off, plus how much later each held task is (late)."""
    before, after = _done_at(robot, base, travel), _done_at(robot, plan, travel)
    late = waiting = 0.0
    for task in tasks:
        done = after.get(task.code, 0.0)
        if task.code == new:
            waiting += task.weight * done
            late += task.weight * max(0.0, done - task.due)
            continue
        was = before.get(task.code, 0.0)
        waiting += task.weight * max(0.0, done - was)
        late += task.weight * (max(0.0, done - task.due) - max(0.0, was - task.due))
    return late, waiting


def allocate_standby_first(
    task: TaskStops, robots: Sequence[RobotRoute], travel_time: TravelTime
) -> Allocation | None:
    """The paper's rule (Sec. 3.1.2), in full: a standby robot (holding no task) takes the task;
    of several, the one that reaches the task's first pick-up soonest. Only when no standby
    robot can take it does it go to the robot whose route it lengthens least (`allocate`).

    Ties go to the robot given fewer tasks, then to the smallest code. `added_cost` is the
    added travel.
    """
    travel = _Travel(travel_time)
    best = None
    for robot in _distinct(r for r in robots if not r.tasks):
        plan = _plan(robot, (task,), travel)
        if not plan or not math.isfinite(plan.cost):
            continue
        reach = travel[robot.start][plan.stops[0].place]
        if best is None or reach < best[0] - TOLERANCE:
            best = (reach, Allocation(robot.robot, plan, plan.cost))
    return best[1] if best else allocate(task, robots, travel_time)


@lru_cache(maxsize=1024)
def _held_plan(robot: RobotRoute, travel_time: TravelTime) -> Plan | None:
    """The robot's best route as it is (_route): the same for every task of a batch that does
    not go to it. By route, not by robot (`robot` is nameless): robots alike share it."""
    travel = _Travel(travel_time)
    if (
        BOUNDED_FROM <= len(robot.tasks) + 1 <= EXACT_TASK_LIMIT
        and (travel_time, _shape(robot, robot.tasks)) not in _ORDERS
    ):
        _finishing(robot, robot.tasks, travel)  # solved backwards: it bounds the offers to come
    return _route(robot, robot.tasks, travel)


def _distinct(robots: Iterable[RobotRoute]) -> list[RobotRoute]:
    """The robots by _rank, without those whose route (start, load, tasks, pace, ...) is the
    same as a robot's before them: they would be made the same offer, and ties go to the
    first by _rank. A burst offers each task to every robot; most stand empty at a few docks."""
    seen, distinct = set(), []
    for robot in sorted(robots, key=_rank):
        if (route := robot.nameless) not in seen:
            seen.add(route)
            distinct.append(robot)
    return distinct


def _done_at(robot: RobotRoute, plan: Plan, travel: _Travel) -> dict[str, float]:
    """Per task, the seconds from now until its last stop in the plan is done (travel and
    the robot's dwell at each stop)."""
    done, clock, here = {}, 0.0, robot.start
    for stop in plan.stops:
        clock += travel[here][stop.place] * robot.pace + robot.dwell
        done[stop.task] = clock
        here = stop.place
    return done


def _route(
    robot: RobotRoute, tasks: tuple[TaskStops, ...], travel: _Travel, *, limit: float = math.inf
) -> Plan | None:
    """The robot's best route (module docstring): least travel unless a deadline or a
    priority's weight says otherwise. None if an exact least-travel route costs more than
    `limit`: every route of these tasks costs at least that much."""
    base = _plan(robot, tasks, travel, limit=limit)
    base = base and _soonest_due_first(base, tasks)
    if base is None or len(tasks) > EXACT_TASK_LIMIT or len(tasks) < 2:
        return base
    done = _done_at(robot, base, travel)
    hurried = [t for t in tasks if t.weight > 1.0 or done.get(t.code, 0.0) > t.due]
    if not hurried:
        return base
    best, best_key = base, _route_key(robot, base, tasks, travel)
    for first in sorted(hurried, key=lambda t: (-t.weight, t.due, t.code)):
        plan = _plan_first(robot, first, [t for t in tasks if t is not first], travel)
        if plan is None or not math.isfinite(plan.cost):
            continue
        plan = _soonest_due_first(plan, tasks)
        key = _route_key(robot, plan, tasks, travel)
        if key[0] < best_key[0] or (key[0] == best_key[0] and key[1] < best_key[1] - TOLERANCE):
            best, best_key = plan, key
    return best


def _soonest_due_first(plan: Plan, tasks: Sequence[TaskStops]) -> Plan:
    """The plan with each run of drop-offs at one place in order of due time, then of weight.

    A route's least travel does not say in which order to unload at one station, and the
    search's order is arbitrary; with a dwell at each stop, it decides which delivery is
    done first (a STAT sample unloaded after the routine ones at the lab). Unloading only
    lowers the load, so any order of them keeps within capacity; the travel is the same.
    """
    urgency = {task.code: (task.due, -task.weight) for task in tasks}
    stops = plan.stops
    if len(set(urgency.values())) < 2:  # all alike: nothing to order them by
        return plan
    if not any(_same_drop_place(a, b) for a, b in zip(stops, stops[1:], strict=False)):
        return plan
    ordered, start = [], 0
    while start < len(stops):
        end = start + 1
        while end < len(stops) and _same_drop_place(stops[start], stops[end]):
            end += 1
        ordered += sorted(stops[start:end], key=lambda stop: urgency[stop.task])  # stable
        start = end
    return replace(plan, stops=tuple(ordered))


def _same_drop_place(first: Stop, other: Stop) -> bool:
    return first.action == other.action == DROPOFF and first.place == other.place


def _route_key(robot, plan: Plan, tasks, travel: _Travel) -> tuple[int, float]:
    """(weighted lateness to the second, travel + the extra weight of each task's done time)."""
    done = _done_at(robot, plan, travel)
    late = sum(t.weight * max(0.0, done.get(t.code, 0.0) - t.due) for t in tasks)
    hurry = sum((t.weight - 1.0) * done.get(t.code, 0.0) for t in tasks)
    return math.floor(late), plan.cost + hurry


def _plan_first(robot, first: TaskStops, others: list[TaskStops], travel: _Travel):
    """The least-travel route doing every stop of `first` before any other stop."""
    problem = _problem(robot, (first, *others), travel)
    ahead = (1 << (len(first.pickups) + len(first.dropoffs))) - 1
    for j in range(ahead.bit_length(), len(problem.stops)):
        problem.needs[j] |= ahead
    found = _held_karp(problem, math.inf, _least_arrivals(problem))
    return found and _as_plan(problem, *found)


def added_cost_lower_bound(task: TaskStops, robot: RobotRoute, travel_time: TravelTime) -> float:
    """A lower bound on how much `task` lengthens the robot's best route (metric times only)."""
    return _lower_bound(task, robot, _Travel(travel_time))


def cheapest_insertion(
    robot: RobotRoute, order: Sequence[Stop], task: TaskStops, travel_time: TravelTime
) -> Plan | None:
    """`order` with the task's pick-ups and its drop-offs inserted, each as one block, where they
    lengthen it least without overloading the robot; None if they fit nowhere."""
    return _inserted(robot, order, task, _Travel(travel_time))


def enumerate_best_plan(
    robot: RobotRoute,
    travel_time: TravelTime,
    *,
    extra: TaskStops | None = None,
    deadline: float | None = None,
) -> Plan | None:
    """The paper's brute force: cost every ordering of the stops, keep the cheapest.

    Orderings that break precedence or capacity are abandoned as soon as they do. Raises
    TimeoutError once time.perf_counter() passes `deadline`.
    """
    tasks = robot.tasks + ((extra,) if extra else ())
    problem = _problem(robot, tasks, _Travel(travel_time))
    found = _Enumeration(problem, deadline).run()
    return found and _as_plan(problem, *found)


def route_cost(start: str, stops: Sequence[Stop], travel_time: TravelTime) -> float:
    places = [start, *(stop.place for stop in stops)]
    return sum(travel_time(a, b) for a, b in zip(places, places[1:], strict=False))


class _Travel(dict):
    """travel_time memoised per origin: self[a][b]."""

    def __init__(self, travel_time: TravelTime):
        super().__init__()
        self.travel_time = travel_time
        self.saw_infinity = False

    def __missing__(self, origin: str) -> _Row:
        row = self[origin] = _Row(origin, self)
        return row


class _Row(dict):
    def __init__(self, origin: str, travel: _Travel):
        super().__init__()
        self.origin = origin
        self.travel = travel

    def __missing__(self, destination: str) -> float:
        seconds = self[destination] = float(self.travel.travel_time(self.origin, destination))
        if not math.isfinite(seconds):
            self.travel.saw_infinity = True
        return seconds


def _is_better(offer: Allocation, best: Allocation | None, rank: dict) -> bool:
    if best is None or offer.added_cost < best.added_cost - TOLERANCE:
        return True
    tied = offer.added_cost <= best.added_cost + TOLERANCE
    return tied and rank[offer.robot] < rank[best.robot]


def _rank(robot: RobotRoute) -> tuple[int, str]:
    """How ties between equally good offers go: to the robot given fewer tasks, then to the
    smallest code."""
    return robot.wear, robot.robot


def _offer(task, robot, travel, *, margin: float, metric: bool) -> Allocation | None:
    """The robot's route with the task, if that adds at most `margin` (within tolerance)."""
    if len(robot.tasks) + 1 > EXACT_TASK_LIMIT:
        return _heuristic_offer(task, robot, travel)
    problem = _problem(robot, (*robot.tasks, task), travel)
    held = len(problem.stops) - len(task.pickups) - len(task.dropoffs)
    base = _Finishing(problem.first(held))
    if base.cost is None:
        return None
    if metric and not travel.saw_infinity:
        limit = (
            base.cost + margin if margin < math.inf else _insertion_cost(task, robot, base, problem)
        )
        found = _held_karp(problem, limit, _savings(problem, held), base.tail(problem.times))
    else:
        found = _held_karp(problem, base.cost + margin, _least_arrivals(problem))
    return found and Allocation(robot.robot, _as_plan(problem, *found), found[0] - base.cost)


def _insertion_cost(task, robot, base: _Finishing, problem: _Problem) -> float:
    """A feasible route's cost, to prune the exact search before any offer is known: `task`
    (the last of `problem`) inserted into the best order of the other stops, which `base`
    solved (the route without the task, or one alike: another robot's, hence problem.stops)."""
    order = [problem.stops[j] for j in base.order()]
    plan = _inserted(robot, order, task, problem.travel)
    return plan.cost if plan else math.inf


def _heuristic_offer(task, robot, travel) -> Allocation | None:
    """Past EXACT_TASK_LIMIT: the task inserted into the robot's (kept) route, then or-opt."""
    base = _plan(robot, robot.tasks, travel)
    plan = base and _plan(robot, (*robot.tasks, task), travel)
    return plan and Allocation(robot.robot, plan, plan.cost - base.cost)


def _plan(
    robot: RobotRoute, tasks: tuple[TaskStops, ...], travel: _Travel, *, limit: float = math.inf
) -> Plan | None:
    found = _least_travel_order(robot, tasks, travel, limit=limit)
    if found is None:
        return None
    stops = [stop for task in tasks for stop in _stops(task)]
    exact = len(tasks) <= EXACT_TASK_LIMIT
    return Plan(tuple(stops[j] for j in found[1]), found[0], exact=exact)


def _heuristic_order(robot: RobotRoute, tasks: tuple[TaskStops, ...], travel: _Travel):
    """(cost, stop numbers in order) of the last task inserted into the route of the others,
    then or-opt; None if that finds no feasible order."""
    earlier = _plan(robot, tasks[:-1], travel)
    plan = earlier and _inserted(robot, earlier.stops, tasks[-1], travel)
    plan = plan and _improved(robot, plan, travel)
    if plan is None:
        return None
    numbers = {stop: j for j, stop in enumerate(s for task in tasks for s in _stops(task))}
    return plan.cost, tuple(numbers[stop] for stop in plan.stops)


# Exact: Held-Karp with precedence and capacity.

# Least-travel orders solved, by the shape of the problem: the robot's start, load and
# capacities and, per task in order, the places and load changes of its stops; not the tasks'
# codes, due times or weights, which the least-travel order does not depend on. A burst offers
# task after task to the same robots, whose routes change only when they take one, and many
# tasks of a burst go between the same two stations (a ward's samples to the lab): half the
# solves of a batch of 100 (bench/latency.py's burst) are then looked up, not solved again,
# though the cheaper half (short routes): the batch's allocator CPU fell by about a tenth.
# Beyond EXACT_TASK_LIMIT the order is the heuristic's, which depends on the shape alone too;
# kept, a route of k tasks offered a new one inserts it into the kept route of the k, instead
# of building that one again by inserting each task after the limit's first ones.
# Cleared whole when full; keyed by the travel-time function too (one per site map version).
_ORDERS: dict = {}
ORDERS_KEPT = 20_000
_UNSOLVED = object()


def _least_travel_order(
    robot: RobotRoute, tasks: Sequence[TaskStops], travel: _Travel, *, limit: float = math.inf
):
    """(cost, stop numbers in order) of the least-travel route of the tasks' stops, numbered
    as _problem numbers them (the heuristic's beyond EXACT_TASK_LIMIT tasks); None if no order
    is feasible (or the heuristic finds none), or if the exact one costs more than `limit`."""
    key = (travel.travel_time, _shape(robot, tasks))
    found = _ORDERS.get(key, _UNSOLVED)
    if isinstance(found, _Above):
        if limit <= found.limit:
            return None
        found = _UNSOLVED
    if found is _UNSOLVED:
        if len(tasks) <= EXACT_TASK_LIMIT:
            found = _exact_order(robot, tasks, travel, limit)
        else:
            found = _heuristic_order(robot, tasks, travel)
        _order_keep(travel, key[1], _Above(limit) if found is None and limit < math.inf else found)
    return found


def _order_keep(travel: _Travel, shape: tuple, found, *, solved_otherwise: bool = False) -> None:
    """Keep an order found. With solved_otherwise (the backward solve's order), only where no
    order is kept: one already handed out stays, as equal-cost orders may do tasks at other
    times."""
    key = (travel.travel_time, shape)
    kept = _ORDERS.get(key, _UNSOLVED)
    if solved_otherwise and kept is not _UNSOLVED and not isinstance(kept, _Above):
        return
    _keep(_ORDERS, ORDERS_KEPT, key, found)


def _keep(store: dict, most: int, key, value) -> None:
    """store[key] = value, the store cleared whole first if it holds `most` already."""
    if len(store) >= most:
        store.clear()
    store[key] = value


@dataclass(frozen=True)
class _Above:
    """Kept for a route whose exact least travel is known to be more than `limit` (or none)."""

    limit: float


# A route of BOUNDED_FROM tasks or more whose last task is all to be picked up (a new task
# offered) is solved as allocate() solves an offer: the route without that task, solved
# backwards once and kept by shape (_FINISHING), bounds the forward search from below, and the
# search keeps only states that can come in under both the task inserted into that route and
# `limit`, what the route may cost for the robot to beat the best offer so far
# (_winning_cost). A batch offers task after task to the same routes: in bench/allocation.py's
# burst this cut the allocator's CPU by two fifths. With fewer tasks the backward solve costs
# more than it saves: offers to 10 or 50 robots holding 3 tasks each took a fifth longer
# bounded from 4 tasks (bench/allocation.py --rule), and equal with 4 held.
BOUNDED_FROM = 5


def _exact_order(robot: RobotRoute, tasks: Sequence[TaskStops], travel: _Travel, limit: float):
    """(cost, stop numbers in order) of the least-travel route, if it costs at most `limit`."""
    problem = _problem(robot, tasks, travel)
    if len(tasks) < BOUNDED_FROM or travel.saw_infinity or not _all_picked_up(tasks[-1]):
        found = _held_karp(problem, limit, _least_arrivals(problem))
    else:
        found = _bounded_by_held_route(robot, tasks, travel, problem, limit)
    return found and (found[0], tuple(found[1]))


def _bounded_by_held_route(robot, tasks, travel: _Travel, problem: _Problem, limit: float):
    """_held_karp's answer for `problem`, bounded by the route without its last task."""
    held = len(problem.stops) - len(_stops(tasks[-1]))
    base = _finishing(robot, tasks[:-1], travel)
    if base.cost is None:
        return None
    limit = min(limit, _insertion_cost(tasks[-1], robot, base, problem))
    return _held_karp(problem, limit, _savings(problem, held), base.tail(problem.times))


def _all_picked_up(task: TaskStops) -> bool:
    """Whether the route picks up every item the task drops off (none is on board yet): then
    the route without the task is the robot's route of the other tasks, which bounds it."""
    picked = sum(stop.load_change for stop in task.pickups)
    return picked == -sum(stop.load_change for stop in task.dropoffs)


_FINISHING: dict = {}
FINISHING_KEPT = 512


def _finishing(robot: RobotRoute, tasks: Sequence[TaskStops], travel: _Travel) -> _Finishing:
    shape = _shape(robot, tasks)
    found = _FINISHING.get((travel.travel_time, shape))
    if found is None:
        found = _Finishing(_problem(robot, tasks, travel))
        _keep(_FINISHING, FINISHING_KEPT, (travel.travel_time, shape), found)
        order = None if found.cost is None else (found.cost, found.order())
        _order_keep(travel, shape, order, solved_otherwise=True)
    return found


def _shape(robot: RobotRoute, tasks: Sequence[TaskStops]) -> tuple:
    shapes = tuple(task.shape for task in tasks)
    return robot.start, robot.load, robot.capacity, robot.lockable, robot.secure_load, shapes


def _stops_shape(stops: Sequence[Stop]) -> tuple:
    return tuple((stop.place, stop.load_change, stop.secure) for stop in stops)


@dataclass
class _Problem:
    """A route's stops by number: point 0 is the start, point j + 1 is stops[j]."""

    travel: _Travel
    stops: list[Stop]
    times: list[list[float]]  # times[a][b]: travel from point a to point b
    needs: list[int]  # per stop, the bitmask of stops that must come before it
    changes: list[int]  # load changes, packed (_packing)
    load: int  # packed
    top: int  # the largest packed load within capacity
    fits: _Fits | None  # with secure items: the packed loads within capacity, else None

    def holds(self, load: int) -> bool:
        """Whether a packed load is within capacity (the hot loops inline this)."""
        return _holds(load, self.top, self.fits)

    def first(self, count: int) -> _Problem:
        """The same route with only its first `count` stops."""
        times = [row[: count + 1] for row in self.times[: count + 1]]
        changes = self.changes[:count]
        stops, needs = self.stops[:count], self.needs[:count]
        load, top, fits = self.load, self.top, self.fits
        return _Problem(self.travel, stops, times, needs, changes, load, top, fits)

    @cached_property
    def into(self) -> list[list[float]]:
        """into[j][a]: travel from point a to stop j."""
        return [[row[j + 1] for row in self.times] for j in range(len(self.stops))]

    @cached_property
    def unlocks(self) -> list[list[int]]:
        """unlocks[j]: the stops that need stop j first."""
        numbers = range(len(self.stops))
        return [[d for d, need in enumerate(self.needs) if need >> j & 1] for j in numbers]

    def first_ready(self) -> list[int]:
        return [j for j, need in enumerate(self.needs) if not need]

    def ready_after(self, ready: list[int], j: int, done: int) -> list[int]:
        """The stops that may come next once stop j is done too (`done` includes j)."""
        unlocked = [d for d in self.unlocks[j] if not self.needs[d] & ~done]
        return [i for i in ready if i != j] + unlocked


def _problem(robot: RobotRoute, tasks: Sequence[TaskStops], travel: _Travel) -> _Problem:
    stops, needs = [], []
    for task in tasks:
        pickups = ((1 << len(task.pickups)) - 1) << len(stops)
        stops += task.pickups + task.dropoffs
        needs += [0] * len(task.pickups) + [pickups] * len(task.dropoffs)
    places = [robot.start, *(stop.place for stop in stops)]
    times = [[row[place] for place in places] for row in map(travel.__getitem__, places)]
    load, change, top, fits = _packing(robot, stops)
    changes = [stop.load_change for stop in stops] if fits is None else list(map(change, stops))
    return _Problem(travel, stops, times, needs, changes, load, top, fits)


# Two capacities, one number: a route's load packs the items on board and, SECURE times over,
# the secure ones among them (each needing a lockable compartment), so the searches below carry
# one integer per state. Item counts stay far below SECURE. Without secure items the load is
# the item count and the check the plain comparison with the capacity it always was.
SECURE = 1 << 20


class _Fits:
    """The packed loads with at most `capacity` items, `lockable` of them secure."""

    __slots__ = ("capacity", "lockable")

    def __init__(self, capacity: int, lockable: int):
        self.capacity, self.lockable = capacity, lockable

    def __contains__(self, load: int) -> bool:
        secure, items = divmod(load, SECURE)  # items off range (negative, say) fail below
        return 0 <= items <= self.capacity and 0 <= secure <= min(self.lockable, items)


def _packing(robot: RobotRoute, stops: Sequence[Stop]):
    """(the packed load on board, the packed change of a stop, the largest packed load that
    fits, the packed loads that fit or None without secure stops or items on board)."""
    if not robot.secure_load and not any(stop.secure for stop in stops):
        return robot.load, _item_change, robot.capacity, None
    load = robot.load + robot.secure_load * SECURE
    top = robot.capacity + robot.lockable * SECURE
    return load, _packed_change, top, _Fits(robot.capacity, robot.lockable)


def _holds(load: int, top: int, fits: _Fits | None) -> bool:
    return 0 <= load <= top and (fits is None or load in fits)


def _item_change(stop: Stop) -> int:
    return stop.load_change


def _packed_change(stop: Stop) -> int:
    return stop.load_change * (1 + SECURE) if stop.secure else stop.load_change


def _as_plan(problem: _Problem, cost: float, order: list[int]) -> Plan:
    return Plan(tuple(problem.stops[j] for j in order), cost, exact=True)


def _held_karp(problem: _Problem, limit: float, lower: list[float], tail=None):
    """The cheapest feasible order costing at most `limit`, as (cost, stop numbers); else None.

    Layer m holds, for each set of m stops that can be done first, the cheapest way found to
    have done them ending at each of them. A state is dropped when its cost plus a lower bound
    on the travel still to come exceeds the limit: the sum of `lower` over the stops left, plus
    tail(done, last) when given.
    """
    if not problem.holds(problem.load) or math.inf in lower:
        return None
    states = {0: (problem.load, sum(lower), problem.first_ready())}
    layers = [{0: {0: 0.0}}]
    bound = min(limit + TOLERANCE, sys.float_info.max)  # so that infinite costs never pass
    for _ in problem.stops:
        layers.append(_next_layer(problem, layers[-1], states, lower, bound, tail))
        if not layers[-1]:
            return None
    ((done, ends),) = layers[-1].items()
    last = min(ends, key=ends.__getitem__)
    return ends[last], _walk_back(problem, layers, done, last)


def _least_arrivals(problem: _Problem) -> list[float]:
    """Per stop, the least travel time into it from any point that may precede it."""
    arrivals = []
    for j, need in enumerate(problem.needs):
        before = [0] if need == 0 else []
        before += [i + 1 for i, other in enumerate(problem.needs) if i != j and not other >> j & 1]
        arrivals.append(min((problem.times[i][j + 1] for i in before), default=math.inf))
    return arrivals


def _next_layer(problem, layer, states, lower, bound, tail):
    """Extend every state of `layer` by one stop. The hot loop, so written for speed.

    states[done] = (load on board, sum of `lower` over the stops left, stops that may come next).
    """
    into, changes, top, fits = problem.into, problem.changes, problem.top, problem.fits
    following: dict[int, dict[int, float]] = {}
    for done, ends in layer.items():
        load, rest, ready = states[done]
        for j in ready:
            new_load = load + changes[j]
            if not 0 <= new_load <= top or fits and new_load not in fits:
                continue
            column, cost = into[j], math.inf
            for last, so_far in ends.items():
                if (arrival := so_far + column[last]) < cost:
                    cost = arrival
            rest_after = rest - lower[j]
            key, point = done | 1 << j, j + 1
            if cost + rest_after > bound or (tail and cost + rest_after + tail(key, point) > bound):
                continue
            reached = following.get(key)
            if reached is None:
                following[key] = {point: cost}
                states[key] = (new_load, rest_after, problem.ready_after(ready, j, key))
            elif cost < reached.get(point, math.inf):
                reached[point] = cost
    return following


def _walk_back(problem: _Problem, layers, done: int, point: int) -> list[int]:
    """The stops, in order, of the cheapest way found to reach (done, point)."""
    order, cost = [], layers[-1][done][point]
    for layer in reversed(layers[:-1]):
        order.append(point - 1)
        done ^= 1 << (point - 1)
        point = _predecessor(layer[done], problem.into[point - 1], cost)
        cost = layer[done][point]
    return order[::-1]


def _predecessor(ends: dict[int, float], column: list[float], cost: float) -> int:
    return min(ends, key=lambda last: abs(ends[last] + column[last] - cost))


class _Finishing:
    """Held-Karp run backwards: the least travel to finish the route from each (done, last).

    From the start, that is the best route's cost. It also bounds a longer route holding these
    stops and a new task's: leaving the new stops out of what remains of that route, from any
    of its states, gives a way to finish this one that is no longer (triangle inequality).
    """

    def __init__(self, problem: _Problem):
        self.problem = problem
        self.full = (1 << len(problem.stops)) - 1
        self.states: dict[int, tuple[int, list[int]]] = {}  # done -> (load, stops that may come)
        self.choices: dict[int, list[tuple[int, float]]] = {}  # done -> [(next point, to finish)]
        self.finish: dict[int, dict[int, float]] = {}  # done -> {last point: to finish}
        if problem.holds(problem.load):
            self._sweep(self._reachable())

    @property
    def cost(self) -> float | None:
        cost = self.finish.get(0, {}).get(0, math.inf)
        return cost if cost < math.inf else None

    def order(self) -> tuple[int, ...]:
        done, point, order = 0, 0, []
        while done != self.full:
            point = _cheapest_choice(self.choices[done], self.problem.times[point])
            order.append(point - 1)
            done |= 1 << (point - 1)
        return tuple(order)

    def tail(self, times: list[list[float]]) -> Callable[[int, int], float]:
        """tail(done, point) for a longer route whose first stops are these, with `times`."""
        finish, choices, full, held = self.finish, self.choices, self.full, len(self.problem.stops)
        from_new: dict[tuple[int, int], float] = {}

        def tail(done: int, point: int) -> float:
            done &= full
            if point <= held:
                row = finish.get(done)
                return row.get(point, 0.0) if row else 0.0
            if (done, point) not in from_new:
                row = times[point]
                onward = (row[p] + rest for p, rest in choices.get(done, ()))
                from_new[done, point] = min(onward, default=0.0)
            return from_new[done, point]

        return tail

    def _reachable(self) -> list[dict[int, set[int]]]:
        """Per layer, the sets of stops that can be done first, and the stops they can end at."""
        problem, states = self.problem, self.states
        changes, top, fits = problem.changes, problem.top, problem.fits
        states[0] = (problem.load, problem.first_ready())
        layers = [{0: {0}}]
        for _ in problem.stops:
            following: dict[int, set[int]] = {}
            for done in layers[-1]:
                load, ready = states[done]
                for j in ready:
                    new_load = load + changes[j]
                    if not 0 <= new_load <= top or fits and new_load not in fits:
                        continue
                    key = done | 1 << j
                    lasts = following.get(key)
                    if lasts is None:
                        following[key] = {j + 1}
                        states[key] = (new_load, problem.ready_after(ready, j, key))
                    else:
                        lasts.add(j + 1)
            layers.append(following)
        return layers

    def _sweep(self, layers: list[dict[int, set[int]]]) -> None:
        """Fill `finish` from the last layer back. Hot, so written with plain loops."""
        problem, finish = self.problem, self.finish
        times, changes, top, fits = problem.times, problem.changes, problem.top, problem.fits
        for lasts in layers[-1].values():
            finish[self.full] = dict.fromkeys(lasts, 0.0)
        for layer in reversed(layers[:-1]):
            for done, lasts in layer.items():
                load, ready = self.states[done]
                choices = []
                for j in ready:
                    after = finish.get(done | 1 << j)
                    if after is None:
                        continue
                    new_load = load + changes[j]
                    if 0 <= new_load <= top and (fits is None or new_load in fits):
                        choices.append((j + 1, after[j + 1]))
                if not choices:
                    continue
                self.choices[done] = choices
                row = finish[done] = {}
                for last in lasts:
                    leaving, least = times[last], math.inf
                    for point, rest in choices:
                        if (total := leaving[point] + rest) < least:
                            least = total
                    row[last] = least


def _cheapest_choice(choices: list[tuple[int, float]], row: list[float]) -> int:
    return min(choices, key=lambda choice: row[choice[0]] + choice[1])[0]


def _savings(problem: _Problem, held: int) -> list[float]:
    """Per stop, 0 for the held ones and for each new one the least that leaving it out saves.

    Taking a stop s out from between points a and b saves t(a,s) + t(s,b) - t(a,b), or t(a,s)
    when s comes last, which only stops that no other stop waits for can. Taking out the new
    task's pick-ups, then its drop-offs, from what is left of a route leaves what is left of a
    route of the held stops alone; hence these bound the travel left from below, with tail().
    """
    count = len(problem.stops)
    savings = [0.0] * held
    for j in range(held, count):
        point, into, onward = j + 1, problem.into[j], problem.times[j + 1]
        before = [a for a in range(count + 1) if a != point]
        after = [b for b in range(1, count + 1) if b != point]
        least = min(into[a] for a in before) if not problem.unlocks[j] else math.inf
        for a in before:
            row = problem.times[a]
            detour = min((onward[b] - row[b] for b in after), default=math.inf)
            least = min(least, into[a] + detour)
        savings.append(max(least, 0.0))
    return savings


# The paper's method, kept as the reference.


class _Enumeration:
    CHECK_EVERY = 4096  # complete orderings between looks at the clock

    def __init__(self, problem: _Problem, deadline: float | None):
        self.problem = problem
        self.deadline = deadline
        self.full = (1 << len(problem.stops)) - 1
        self.best: tuple[float, list[int]] | None = None
        self.leaves = 0

    def run(self) -> tuple[float, list[int]] | None:
        if self.problem.holds(self.problem.load):
            self._visit(0, 0, self.problem.load, 0.0, [])
        return self.best

    def _visit(self, point: int, done: int, load: int, cost: float, order: list[int]) -> None:
        if done == self.full:
            self._finish(cost, order)
            return
        problem = self.problem
        for j, need in enumerate(problem.needs):
            new_load = load + problem.changes[j]
            if done >> j & 1 or need & ~done or not problem.holds(new_load):
                continue
            order.append(j)
            self._visit(j + 1, done | 1 << j, new_load, cost + problem.times[point][j + 1], order)
            order.pop()

    def _finish(self, cost: float, order: list[int]) -> None:
        if cost < math.inf and (self.best is None or cost < self.best[0]):
            self.best = (cost, list(order))
        self.leaves += 1
        checks_clock = self.deadline and self.leaves % self.CHECK_EVERY == 0
        if checks_clock and time.perf_counter() > self.deadline:
            raise TimeoutError("enumeration passed its deadline")


# Lower bound on added travel.


def _lower_bound(task: TaskStops, robot: RobotRoute, travel: _Travel) -> float:
    """Travel the task must add to any route of the robot, if times obey the triangle inequality.

    Take the best route with the task and remove its new pick-ups, then its new drop-offs: what
    is left is a valid route without the task, so costs at least the best one. Removing stop s
    from between a and b saves t(a,s) + t(s,b) - t(a,b) (or t(a,s) when s was last), at least
    the least such saving over every pair of points that could have been its neighbours.
    """
    held = list(dict.fromkeys(stop.place for held in robot.tasks for stop in _stops(held)))
    pickups = [stop.place for stop in task.pickups]
    dropoffs = [stop.place for stop in task.dropoffs]
    bound = 0.0
    for i, place in enumerate(pickups):
        others = pickups[:i] + pickups[i + 1 :]
        before, after = [robot.start, *held, *others], [*held, *others, *dropoffs]
        bound += _least_saving(place, before, after, travel, may_be_last=False)
    for i, place in enumerate(dropoffs):
        others = dropoffs[:i] + dropoffs[i + 1 :]
        before, after = [robot.start, *held, *others], [*held, *others]
        bound += _least_saving(place, before, after, travel, may_be_last=True)
    return bound


def _stops(task: TaskStops) -> tuple[Stop, ...]:
    return task.pickups + task.dropoffs


def _least_saving(place, before, after, travel: _Travel, *, may_be_last: bool) -> float:
    onward = travel[place]
    leaving = [onward[b] for b in after]
    least = min(travel[a][place] for a in before) if may_be_last else math.inf
    for a in before if leaving else ():
        row = travel[a]
        least = min(least, row[place] + min(map(sub, leaving, map(row.__getitem__, after))))
    return max(least, 0.0)


# Heuristic: block insertion, then or-opt.


def _inserted(robot: RobotRoute, order: Sequence[Stop], task: TaskStops, travel: _Travel):
    places = [robot.start, *(stop.place for stop in order)]
    loads, secure = _loads(robot.load, order), _loads(robot.secure_load, order, secure=True)
    pickups, dropoffs = [s.place for s in task.pickups], [s.place for s in task.dropoffs]
    carried = sum(stop.load_change for stop in task.pickups)
    locked = carried if any(stop.secure for stop in task.pickups) else 0
    best = None
    for i in range(1, len(places) + 1):
        peak = secure_peak = -math.inf
        for j in range(i, len(places) + 1):
            peak, secure_peak = max(peak, loads[j - 1]), max(secure_peak, secure[j - 1])
            if peak + carried > robot.capacity or locked and secure_peak + locked > robot.lockable:
                break
            if i == j:
                cost = _detour(places, i, pickups + dropoffs, travel)
            else:
                cost = _detour(places, i, pickups, travel) + _detour(places, j, dropoffs, travel)
            if best is None or cost < best[0] - TOLERANCE:
                best = (cost, i, j)
    if best is None:
        return None
    _, i, j = best
    stops = [*order[: i - 1], *task.pickups, *order[i - 1 : j - 1], *task.dropoffs, *order[j - 1 :]]
    return _checked_plan(robot, stops, travel)


def _loads(load: int, order: Sequence[Stop], *, secure: bool = False) -> list[int]:
    """Load on board (only its secure items, with `secure`) on leaving the start, then each stop."""
    loads = [load]
    for stop in order:
        loads.append(loads[-1] + (stop.load_change if stop.secure or not secure else 0))
    return loads


def _detour(places: list[str], i: int, block: list[str], travel: _Travel) -> float:
    """Added travel of visiting `block` between places[i - 1] and places[i] (if any)."""
    inside = sum(travel[a][b] for a, b in zip(block, block[1:], strict=False))
    cost = travel[places[i - 1]][block[0]] + inside if block else 0.0
    if block and i < len(places):
        cost += travel[block[-1]][places[i]] - travel[places[i - 1]][places[i]]
    return cost


def _improved(robot: RobotRoute, plan: Plan, travel: _Travel) -> Plan:
    """Or-opt: move runs of 1 to 3 stops elsewhere while that shortens the route."""
    while True:
        better = next(_better_moves(robot, plan, travel), None)
        if better is None:
            return plan
        plan = better


def _better_moves(robot: RobotRoute, plan: Plan, travel: _Travel):
    """Shorter feasible routes, each one run moved; a move's gain is found from the four or
    five legs it changes, so a pass over a route of n stops costs O(n²), not O(n³)."""
    stops = list(plan.stops)
    places = [robot.start, *(stop.place for stop in stops)]
    for length in (1, 2, 3):
        for i in range(len(stops) - length + 1):
            first, last = places[i + 1], places[i + length]
            after = places[i + length + 1] if i + length + 1 < len(places) else None
            gain = travel[places[i]][first] + _leg_change(travel, places[i], after, first, last)
            rest = stops[:i] + stops[i + length :]
            rest_places = places[: i + 1] + places[i + length + 1 :]
            for j in range(len(rest) + 1):
                if j == i:
                    continue  # where it was
                b = rest_places[j + 1] if j + 1 < len(rest_places) else None
                added = travel[rest_places[j]][first] + _leg_change(
                    travel, rest_places[j], b, first, last
                )
                if added - gain >= -TOLERANCE:
                    continue
                candidate = rest[:j] + stops[i : i + length] + rest[j:]
                cost = _cost(robot.start, candidate, travel)
                if cost < plan.cost - TOLERANCE and _is_feasible(robot, candidate):
                    yield Plan(tuple(candidate), cost, exact=False)


def _leg_change(travel: _Travel, a: str, b: str | None, first: str, last: str) -> float:
    """With a run first..last between a and b: last -> b replaces a -> b (b None: the route
    ends with the run). The run's own legs and a -> first are counted by the caller."""
    if b is None:
        return 0.0
    return travel[last][b] - travel[a][b]


def _checked_plan(robot: RobotRoute, stops: list[Stop], travel: _Travel) -> Plan | None:
    cost = _cost(robot.start, stops, travel)
    if cost == math.inf or not _is_feasible(robot, stops):
        return None
    return Plan(tuple(stops), cost, exact=False)


def _cost(start: str, stops: Sequence[Stop], travel: _Travel) -> float:
    places = [start, *(stop.place for stop in stops)]
    return sum(travel[a][b] for a, b in zip(places, places[1:], strict=False))


def _is_feasible(robot: RobotRoute, stops: Sequence[Stop]) -> bool:
    """Every drop-off after all its task's pick-ups, load within capacity throughout (and
    secure items within the lockable compartments)."""
    waiting = Counter(stop.task for stop in stops if stop.action == PICKUP)
    load, change, top, fits = _packing(robot, stops)
    if not _holds(load, top, fits):
        return False
    for stop in stops:
        if stop.action == PICKUP:
            waiting[stop.task] -= 1
        elif waiting[stop.task]:
            return False
        load += change(stop)
        if not _holds(load, top, fits):
            return False
    return True
