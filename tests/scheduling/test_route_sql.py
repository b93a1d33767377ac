"""The scheduler's plain SQL reads what its querysets read: the stops of the tasks on robots'
routes, in order, with their tasks (scheduling.selectors._route_stops, _route_stops_of), and
a robot's current plan with its message (robot_plan_current)."""

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from boards.services import board_post
from scheduling.models import RobotPlan, Task
from scheduling.selectors import _route_stops, _route_stops_of, robot_plan_current
from tests import factories
from tests.scheduling.conftest import request

pytestmark = pytest.mark.django_db


def _values(instance) -> dict:
    return {f.attname: getattr(instance, f.attname) for f in instance._meta.concrete_fields}


def _rows(stops) -> list[tuple[dict, dict]]:
    return [(_values(stop), _values(stop.task)) for stop in stops]


@pytest.fixture
def routes(r1, r2, site):
    """Tasks of each status on R1 and R2, one picked up with its pick-up done, and one of
    another site's robot."""
    for robot, status in [
        (r1, "assigned"),
        (r1, "picked_up"),
        (r1, "completed"),
        (r2, "acknowledged"),
        (r2, "cancelled"),
        (None, "due"),
    ]:
        task = request(site, pickups=("1F-PHARM", "2F-LAB"), dropoffs=("3F-WARD",))
        Task.objects.filter(pk=task.pk).update(status=status, robot=robot, eta=timezone.now())
        if status == "picked_up":
            task.stops.filter(index=0).update(done_at=timezone.now())
    other_site = factories.site_create(site="other")
    elsewhere = request(other_site)
    robot = factories.robot_create(other_site, "R9")
    Task.objects.filter(pk=elsewhere.pk).update(status="assigned", robot=robot)
    return site


def test_one_robots_stops_are_those_of_the_queryset(routes, r1):
    expected = _route_stops_of(task__robot_id=r1.pk)

    with CaptureQueriesContext(connection) as queries:
        found = _route_stops({r1.pk: r1})

    assert _rows(found) == _rows(expected)
    assert [stop.task.status for stop in found] == ["assigned"] * 3 + ["picked_up"] * 3
    assert found[3].done_at is not None  # its first pick-up
    assert len(queries) == 1


def test_a_sites_robots_stops_are_those_of_the_queryset(routes, r1, r2, site):
    expected = _route_stops_of(task__site_id=site.pk, task__robot__isnull=False)

    found = _route_stops({r1.pk: r1, r2.pk: r2})

    assert _rows(found) == _rows(expected)
    assert {stop.task.robot_id for stop in found} == {r1.pk, r2.pk}
    assert len(found) == 9
    tasks = {stop.task_id: stop.task for stop in found}
    assert all(stop.task is tasks[stop.task_id] for stop in found)


def test_the_current_plan_is_the_querysets_with_its_message_or_none(r1, r2, site):
    message = board_post(robot=r1, type="plan", body={"plan_version": 3, "stops": []})
    RobotPlan.objects.create(robot=r1, version=3, body=message.body, message=message)
    RobotPlan.objects.create(robot=r2, version=1, body={"stops": []}, message=None)
    expected = RobotPlan.objects.select_related("message").get(robot=r1)

    found = robot_plan_current(r1.pk)

    assert _values(found) == _values(expected)
    assert _values(found.message) == _values(expected.message)
    assert found.message.is_pending
    assert robot_plan_current(r2.pk).message is None
    assert robot_plan_current(factories.robot_create(site, "R3").pk) is None
