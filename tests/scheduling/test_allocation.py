"""Allocation: the robot whose remaining route a task lengthens least, within battery,
capacity and presence; urgent first; no N+1; never two robots or two plans on one route."""

import threading

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext

from boards.models import BoardMessage
from robots.models import Robot, Waypoint
from robots.selectors import robots_for_allocation
from scheduling.models import Task, TaskTransition
from scheduling.selectors import robot_routes
from scheduling.services import due_sweep, task_allocate
from scheduling.services.allocation import NO_ROBOT, NO_ROUTE
from tests import factories
from tests.scheduling.conftest import Beater, event, pending_plans, request, robot_ready, route


def allocated(task: Task) -> Robot | None:
    assert task_allocate(task_id=task.pk) in (True, False)
    task.refresh_from_db()
    return task.robot


def assert_feasible(stops: list[tuple], capacity: int, on_board=()) -> None:
    """Every drop-off after its task's pick-ups; at most `capacity` items on board."""
    picked, load = set(on_board), len(on_board)
    for task, _stop, action, _waypoint in stops:
        if action == "pickup":
            picked.add(task)
            load += 1
        else:
            assert task in picked, stops
            load -= 1
        assert 0 <= load <= capacity, stops


def test_it_gives_a_task_to_the_robot_it_costs_least(r1, r2, site):
    # R1's dock is 1 s closer to the pharmacy than R2's.
    task = request(site)

    assert allocated(task) == r1
    [plan] = pending_plans(r1)
    assert route(plan.body) == [
        (task.code, 0, "pickup", "1F-PHARM"),
        (task.code, 1, "dropoff", "2F-LAB"),
    ]
    assert plan.body["stops"][1]["via"] == ["1F-ELEV-WAIT", "2F-ELEV-WAIT"]
    assert "via" not in plan.body["stops"][0]
    assert pending_plans(r2) == []


def test_idle_robots_start_from_where_they_are(r1, r2, site):
    robot_ready(r2, at="3F-WARD")

    assert allocated(request(site, pickups=("3F-WARD",), dropoffs=("2F-LAB",))) == r2


def test_it_adds_a_task_to_a_busy_robot_when_that_is_cheapest(r1, r2, site):
    first, second = request(site), request(site, receiver="Dr Lee")
    assert allocated(first) == r1

    assert allocated(second) == r1

    plan = pending_plans(r1)[-1].body
    assert plan["plan_version"] == 2
    assert set(plan["tasks"]) == {first.code, second.code}
    stops = route(plan)
    assert sorted(stops) == sorted(
        [
            (t.code, i, a, w)
            for t in (first, second)
            for i, a, w in [(0, "pickup", "1F-PHARM"), (1, "dropoff", "2F-LAB")]
        ]
    )
    assert_feasible(stops, capacity=4)
    assert stops[:2] == [
        (first.code, 0, "pickup", "1F-PHARM"),
        (second.code, 0, "pickup", "1F-PHARM"),
    ]


def test_a_full_robot_does_not_take_a_task_that_would_overload_it(r1, r2, site):
    Robot.objects.filter(pk=r1.pk).update(capacity=1)
    first, second = request(site), request(site)
    assert allocated(first) == r1

    # Carrying both at once is impossible; a round trip back costs more than R2 coming.
    assert allocated(second) == r2


def test_a_robot_of_small_capacity_serves_tasks_one_after_the_other(r1, site):
    Robot.objects.filter(pk=r1.pk).update(capacity=1)
    first, second = request(site), request(site)

    assert allocated(first) == allocated(second) == r1

    stops = route(pending_plans(r1)[-1].body)
    assert [action for _, _, action, _ in stops] == ["pickup", "dropoff", "pickup", "dropoff"]
    assert_feasible(stops, capacity=1)


def test_a_picked_up_task_only_has_its_dropoffs_left(r1, site):
    first = request(site)
    allocated(first)
    beater = Beater(r1)
    beater.ack_all(beater.beat())
    beater.beat(waypoint="1F-PHARM", events=[event("loaded", first.code, 0)])

    second = request(site, pickups=("3F-WARD",), dropoffs=("1F-PHARM",))
    assert allocated(second) == r1

    stops = route(pending_plans(r1)[-1].body)
    assert (first.code, 0, "pickup", "1F-PHARM") not in stops
    assert_feasible(stops, capacity=4, on_board=[first.code])


@pytest.mark.parametrize(
    "state",
    [
        {"battery": 0.1},  # below the site's threshold (0.2)
        {"battery": None},  # never reported one
        {"status": "error"},
        {"status": "paused"},
        {"presence": "offline"},
    ],
)
def test_it_only_offers_tasks_to_available_robots(r1, r2, site, state):
    Robot.objects.filter(pk=r1.pk).update(**state)

    assert allocated(request(site)) == r2


def test_a_robot_paused_after_it_was_read_is_passed_over(r1, r2, site, monkeypatch):
    from scheduling.services import allocation

    def read_then_operator_pauses_r1(*, site):
        robots = robots_for_allocation(site=site)
        Robot.objects.filter(pk=r1.pk).update(paused_by_operator=True)
        return robots

    monkeypatch.setattr(allocation, "robots_for_allocation", read_then_operator_pauses_r1)

    assert allocated(request(site)) == r2
    assert pending_plans(r1) == []


def test_an_unreachable_robot_may_still_get_a_task(r1, site):
    Robot.objects.filter(pk=r1.pk).update(presence="unreachable")

    assert allocated(request(site)) == r1


def test_a_task_no_robot_can_take_stays_due_and_says_why(r1, site):
    Robot.objects.filter(pk=r1.pk).update(capacity=1)
    too_big = request(site, dropoffs=("2F-LAB", "3F-WARD"))  # two items at once

    assert allocated(too_big) is None
    too_big.refresh_from_db()
    assert (too_big.status, too_big.waiting_reason) == ("due", NO_ROUTE)

    Robot.objects.filter(pk=r1.pk).update(presence="offline")
    nobody = request(site)
    assert allocated(nobody) is None
    nobody.refresh_from_db()
    assert nobody.waiting_reason == NO_ROBOT


def test_allocating_again_changes_nothing(r1, site):
    task = request(site)
    allocated(task)

    assert task_allocate(task_id=task.pk) is False
    assert len(pending_plans(r1)) == 1
    assert task.history.filter(cause="allocation").count() == 1


def test_the_due_sweep_allocates_stat_then_urgent_then_routine_tasks(r1, site):
    routine = request(site)
    urgent = request(site, priority="urgent")
    stat = request(site, priority="stat")

    assert due_sweep() == 3

    allocations = TaskTransition.objects.filter(cause="allocation").order_by("id")
    assert list(allocations.values_list("task_id", flat=True)) == [stat.pk, urgent.pk, routine.pk]


def test_one_allocation_needs_the_same_queries_however_many_robots(site):
    docks = {
        code: Waypoint.objects.get(site=site, code=code) for code in ("1F-DOCK-1", "1F-DOCK-2")
    }

    def counted(robots: int) -> int:
        fleet = [
            robot_ready(factories.robot_create(site, dock=docks[f"1F-DOCK-{1 + n % 2}"]))
            for n in range(robots)
        ]
        for robot in fleet:  # each robot already holds a task
            held = request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
            Task.objects.filter(pk=held.pk).update(status="acknowledged", robot=robot)
        task = request(site)
        with CaptureQueriesContext(connection) as queries:
            assert task_allocate(task_id=task.pk)
        Robot.objects.filter(pk__in=[r.pk for r in fleet]).update(presence="offline")
        return len(queries)

    counted(1)  # warms the per-process map and router caches
    # read the task's site; (savepoint) lock; the task and its stops; the candidates and their
    # routes (1 query each); lock the chosen robot and read its route again; claim the task,
    # record it (and find the site's webhook subscriptions), store ETAs, count it as given to
    # the robot (the wear tie-break); the robot's last plan, supersede it, post the new one,
    # store it
    assert counted(1) == counted(8) == 19


def _in_threads(*calls):
    barrier = threading.Barrier(len(calls))
    results = [None] * len(calls)

    def run(n, call):
        try:
            barrier.wait(timeout=10)
            results[n] = call()
        finally:
            connection.close()

    threads = [threading.Thread(target=run, args=(n, call)) for n, call in enumerate(calls)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30)
    return results


@pytest.mark.django_db(transaction=True)
def test_two_workers_never_give_one_task_to_two_robots(r1, r2, site):
    task = request(site)

    results = _in_threads(
        lambda: task_allocate(task_id=task.pk), lambda: task_allocate(task_id=task.pk)
    )

    assert sorted(results) == [False, True]
    assert task.history.filter(cause="allocation").count() == 1
    assert BoardMessage.objects.filter(type="plan").count() == 1


@pytest.mark.django_db(transaction=True)
def test_two_workers_never_plan_on_the_same_stale_route(r1, site):
    first, second = request(site), request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))

    results = _in_threads(
        lambda: task_allocate(task_id=first.pk), lambda: task_allocate(task_id=second.pk)
    )

    assert results == [True, True]
    posted = list(BoardMessage.objects.filter(robot=r1, type="plan").order_by("id"))
    assert [message.body["plan_version"] for message in posted] == [1, 2]
    assert set(posted[-1].body["tasks"]) == {first.code, second.code}
    assert [message.withdraw_reason for message in posted] == ["superseded", ""]


def test_routes_read_for_some_of_a_sites_robots_hold_their_tasks_only(r1, r2, site):
    held = {}
    for robot, dropoff in ((r1, "3F-WARD"), (r2, "2F-LAB")):
        task = request(site, pickups=("1F-PHARM",), dropoffs=(dropoff,))
        Task.objects.filter(pk=task.pk).update(status="acknowledged", robot=robot)
        held[robot.code] = task
    other = request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
    Task.objects.filter(pk=other.pk).update(status="acknowledged", robot=r1)

    alone = robot_routes(robots=[r1])  # one robot's statement
    both = robot_routes(robots=[r1, r2], excluding=[other.pk])  # the site's, then filtered

    assert set(alone) == {r1.pk}
    assert [t.code for t in alone[r1.pk].route.tasks] == [held["R1"].code, other.code]
    assert [t.code for t in both[r1.pk].route.tasks] == [held["R1"].code]
    assert [t.code for t in both[r2.pk].route.tasks] == [held["R2"].code]
    assert robot_routes(robots=[r2])[r2.pk].signature == both[r2.pk].signature
