"""settings.ALLOCATION_POLICY: online multi-task allocation by added travel or by delivery time,
or single-task (bench/fleet_day.py)."""

from scheduling.models import Task
from scheduling.services import task_allocate
from scheduling.services.allocation import NO_EMPTY_ROBOT
from tests.scheduling.conftest import request


def allocated(task: Task):
    task_allocate(task_id=task.pk)
    task.refresh_from_db()
    return task.robot


def test_multi_adds_a_task_to_a_busy_robot_when_that_is_cheapest(r1, r2, site, settings):
    settings.ALLOCATION_POLICY = "multi"
    assert allocated(request(site)) == r1

    assert allocated(request(site, receiver="Dr Lee")) == r1


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
