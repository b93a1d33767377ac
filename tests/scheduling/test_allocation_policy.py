"""settings.ALLOCATION_POLICY: the paper's rule (a standby robot first), online multi-task
allocation by added travel or by delivery time, or single-task (bench/fleet_day.py)."""

import pytest

from robots.models import Robot
from scheduling.models import Task
from scheduling.services import task_allocate
from scheduling.services.allocation import NO_EMPTY_ROBOT
from tests.scheduling.conftest import request, robot_ready


def allocated(task: Task):
    task_allocate(task_id=task.pk)
    task.refresh_from_db()
    return task.robot


def test_least_travel_adds_a_task_to_a_busy_robot_when_that_is_cheapest(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "least_travel"
    assert allocated(request(site)) == r1

    assert allocated(request(site, receiver="Dr Lee")) == r1


def test_paper_gives_a_task_to_a_standby_robot_before_a_busy_one(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "paper"
    assert allocated(request(site)) == r1

    # The same stops would add no travel to R1's route; R2 holds no task, so it is R2's.
    assert allocated(request(site, receiver="Dr Lee")) == r2


def test_paper_gives_a_task_to_the_standby_robot_nearest_its_pick_up(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "paper"
    robot_ready(r2, at="1F-PHARM")

    assert allocated(request(site)) == r2  # R1 waits at its dock, 20 m further


def test_paper_adds_a_task_where_it_adds_least_travel_when_no_robot_stands_by(
    r1, r2, site, settings
):
    settings.ALLOCATION_POLICY = "paper"
    assert allocated(request(site, dropoffs=("3F-WARD",))) == r1
    assert allocated(request(site, pickups=("2F-LAB",), dropoffs=("1F-PHARM",))) == r2

    # Both robots are busy now: the task has R2's stops, so it lengthens R2's route least.
    same = request(site, receiver="Dr Lee", pickups=("2F-LAB",), dropoffs=("1F-PHARM",))
    assert allocated(same) == r2


def test_delivery_time_adds_a_task_to_a_busy_robot_when_it_delays_nobody(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "delivery_time"
    assert allocated(request(site)) == r1

    assert allocated(request(site, receiver="Dr Lee")) == r1  # same stops: no one waits longer


def test_delivery_time_gives_a_task_to_an_idle_robot_rather_than_delay_one(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "delivery_time"
    first = request(site, pickups=("1F-PHARM",), dropoffs=("3F-WARD",))
    assert allocated(first) == r1

    assert allocated(request(site, pickups=("2F-LAB",), dropoffs=("1F-PHARM",))) == r2


def test_single_offers_a_task_only_to_robots_holding_none(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "single"
    assert allocated(request(site)) == r1

    assert allocated(request(site, receiver="Dr Lee")) == r2


def test_single_leaves_a_task_due_while_every_robot_holds_one(r1, site, settings):
    settings.ALLOCATION_POLICY = "single"
    allocated(request(site))

    waiting = request(site, receiver="Dr Lee")

    assert allocated(waiting) is None
    assert (waiting.status, waiting.waiting_reason) == ("due", NO_EMPTY_ROBOT)


@pytest.mark.parametrize("policy", ["paper", "least_travel", "delivery_time", "single"])
def test_of_equally_good_robots_the_one_given_fewer_tasks_takes_it(r1, r2, site, settings, policy):
    settings.ALLOCATION_POLICY = policy
    robot_ready(r2, at="1F-DOCK-1")  # beside R1: either is as good
    Robot.objects.filter(pk=r1.pk).update(tasks_given=3)

    assert allocated(request(site)) == r2
    r2.refresh_from_db()
    assert r2.tasks_given == 1


def test_the_wear_tie_break_spreads_tasks_over_robots_alike(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "paper"
    robot_ready(r2, at="1F-DOCK-1")
    given = []
    for _ in range(4):
        task = request(site)
        given.append(allocated(task).code)
        Task.objects.filter(pk=task.pk).update(status="delivered")  # each back at the dock

    assert given == ["R1", "R2", "R1", "R2"]
    assert sorted(Robot.objects.values_list("tasks_given", flat=True)) == [2, 2]
