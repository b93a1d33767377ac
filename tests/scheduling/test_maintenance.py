"""Robots in maintenance (scheduling/services/maintenance.py): its tasks not picked up go to
other robots, what it carries is handed back where it was picked up, nothing is planned for
it until an operator (or the time) returns it; recorded who and why."""

from datetime import timedelta

import pytest
import time_machine
from django.test import Client
from django.utils import timezone

from robots.selectors import robots_for_allocation
from scheduling.choices import MaintenanceActionKind, TaskStatus
from scheduling.models import OperatorAction
from scheduling.services import (
    MaintenanceRefused,
    maintenance_due_sweep,
    robot_maintenance_end,
    robot_maintenance_start,
    site_allocate_due,
)
from tests.scheduling.conftest import (
    Beater,
    event,
    pending_plans,
    plans,
    request,
    robot_ready,
    route,
    status,
)


def robots_of(*tasks) -> set[int]:
    for task in tasks:
        task.refresh_from_db()
    return {task.robot_id for task in tasks}


def available(site) -> list[str]:
    return [robot.code for robot in robots_for_allocation(site=site)]


def test_it_hands_its_tasks_on_and_takes_back_what_it_carries(site, r1, r2, operator):
    robot_ready(r2, at="1F-DOCK-2", status="paused")  # not a candidate until r1 is taken out
    first, second, carried = (request(site, allocate_now=True) for _ in range(3))
    assert robots_of(first, second, carried) == {r1.pk}
    beater = Beater(r1)
    beater.ack_all(beater.beat())
    beater.beat(waypoint="1F-PHARM", events=[event("loaded", carried.code, 0)])
    assert status(carried) == TaskStatus.PICKED_UP
    robot_ready(r2, at="1F-DOCK-2")

    action = robot_maintenance_start(robot=r1, reason="wheel motor", by=operator)

    assert (action.action, action.by, action.note) == ("maintenance", operator, "wheel motor")
    assert available(site) == ["R2"]
    assert {status(first), status(second)} == {TaskStatus.DUE}
    assert site_allocate_due(site_id=site.pk) == 2  # one allocation cycle
    assert robots_of(first, second) == {r2.pk}
    carried.refresh_from_db()
    assert (carried.status, carried.robot_id, carried.return_trip) == ("picked_up", r1.pk, True)
    assert route(pending_plans(r1)[-1].body) == [(carried.code, 2, "dropoff", "1F-PHARM")]

    assert robots_of(request(site, allocate_now=True)) == {r2.pk}  # nothing new for r1

    [plan] = plans(beater.beat(waypoint="1F-HALL"))
    beater.ack_all(
        {"messages": [plan]}, waypoint="1F-PHARM", events=[event("unloaded", carried.code, 2)]
    )
    assert status(carried) == TaskStatus.CANCELLED  # handed back at its pick-up point
    assert available(site) == ["R2"]


def test_an_operator_returns_it_and_it_is_offered_tasks_again(site, r1, operator):
    robot_maintenance_start(robot=r1, reason="sensor cleaning", by=operator)
    task = request(site, allocate_now=True)
    assert status(task) == TaskStatus.DUE
    with pytest.raises(MaintenanceRefused):
        robot_maintenance_start(robot=r1, reason="again", by=operator)

    robot_maintenance_end(robot=r1, by=operator)

    assert available(site) == ["R1"]
    assert site_allocate_due(site_id=site.pk) == 1
    kinds = OperatorAction.objects.filter(robot=r1).order_by("pk").values_list("action", "by")
    assert list(kinds) == [
        (MaintenanceActionKind.MAINTENANCE, operator.pk),
        (MaintenanceActionKind.RETURNED, operator.pk),
    ]
    with pytest.raises(MaintenanceRefused):
        robot_maintenance_end(robot=r1, by=operator)


def test_it_returns_to_service_when_its_time_comes(site, r1, operator):
    start = timezone.now()
    until = start + timedelta(hours=2)
    robot_maintenance_start(robot=r1, reason="service", until=until, by=operator, now=start)
    with time_machine.travel(until - timedelta(seconds=1), tick=False):
        assert maintenance_due_sweep() == 0
        assert available(site) == []
    with time_machine.travel(until, tick=False):
        assert maintenance_due_sweep() == 1
        assert maintenance_due_sweep() == 0  # claimed once
    r1.refresh_from_db()
    assert (r1.maintenance_since, r1.maintenance_until, r1.maintenance_reason) == (None, None, "")
    returned = OperatorAction.objects.filter(robot=r1).latest("pk")
    assert (returned.action, returned.by) == (MaintenanceActionKind.RETURNED, None)


def test_a_time_already_passed_is_refused_and_changes_nothing(site, r1, operator):
    with pytest.raises(MaintenanceRefused) as refused:
        robot_maintenance_start(
            robot=r1, reason="x", until=timezone.now() - timedelta(minutes=1), by=operator
        )
    assert refused.value.field == "until"
    r1.refresh_from_db()
    assert r1.maintenance_since is None
    assert not OperatorAction.objects.exists()


@pytest.mark.parametrize(
    ("body", "field"),
    [({}, "reason"), ({"reason": 3}, "reason"), ({"reason": "x", "until": "soon"}, "until")],
)
def test_the_api_refuses_bad_input_naming_the_field(site, r1, staff, body, field):
    api = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")
    answer = api.post("/api/v1/robots/R1/maintenance", body, content_type="application/json")
    assert answer.status_code == 400, answer.content
    assert field in answer.json()["detail"]
    r1.refresh_from_db()
    assert r1.maintenance_since is None


def test_the_api_and_the_robot_page_take_it_out_and_back(site, r1, staff, operator):
    api = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")
    taken = api.post(
        "/api/v1/robots/R1/maintenance", {"reason": "bumper"}, content_type="application/json"
    )
    assert taken.status_code == 200, taken.content
    assert taken.json()["maintenance_reason"] == "bumper"
    again = api.post(
        "/api/v1/robots/R1/maintenance", {"reason": "x"}, content_type="application/json"
    )
    assert again.status_code == 409

    page = Client()
    page.force_login(operator)
    shown = page.get("/robots/R1/").content.decode()
    assert "In maintenance" in shown
    assert "bumper" in shown
    assert page.post("/robots/R1/maintenance", {"in_service": "true"}).status_code == 302
    r1.refresh_from_db()
    assert r1.maintenance_since is None
    assert page.post("/robots/R1/maintenance", {"in_service": "false"}).status_code == 400
    assert api.post("/api/v1/robots/R1/return-to-service").status_code == 409
