"""The allocation's robots in plain SQL (robots.selectors.available_robots_read) are the ones
the ORM's available_robots finds, whatever keeps a robot from new tasks."""

import pytest
from django.db import connection, transaction
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from robots.choices import Presence, RobotStatus
from robots.models import Robot
from robots.selectors import available_robots, available_robots_read
from robots.services import robot_lock_if_available
from tests import factories

pytestmark = pytest.mark.django_db


def _values(instance) -> dict:
    return {f.attname: getattr(instance, f.attname) for f in instance._meta.concrete_fields}


# One robot kept from new tasks by each condition of available_robots, and two that are not.
KEPT_FROM_TASKS = {
    "R-OFFLINE": {"presence": Presence.OFFLINE},
    "R-PAUSED-BY-OPERATOR": {"paused_by_operator": True},
    "R-FAULT": {"fault_at": timezone.now()},
    "R-SENT-TO-CHARGE": {"sent_to_charge": True},
    "R-MAINTENANCE": {"maintenance_since": timezone.now()},
    "R-NEVER-REPORTED": {"battery": None},
    "R-LOW-BATTERY": {"battery": 0.19},
    "R-ERROR": {"status": RobotStatus.ERROR},
    "R-PAUSED": {"status": RobotStatus.PAUSED},
}
AVAILABLE = {
    "R-B-UNREACHABLE": {"presence": Presence.UNREACHABLE, "battery": 0.2},
    "R-A-MOVING": {"status": RobotStatus.MOVING, "errors": ["LIDAR-DIRTY"], "x": 1.5},
}


@pytest.fixture
def fleet(site):
    site.battery_threshold = 0.2
    site.save()
    for code, fields in {**KEPT_FROM_TASKS, **AVAILABLE}.items():
        values = {"presence": Presence.ONLINE, "battery": 0.9, **fields}
        factories.robot_create(site, code, **values)
    factories.robot_create(factories.site_create(site="other"), "R-ELSEWHERE", battery=0.9)
    return site


def test_the_robots_read_are_those_the_orm_finds_by_code_with_their_site(fleet):
    expected = list(available_robots(fleet.pk, fleet.battery_threshold).order_by("code"))

    with CaptureQueriesContext(connection) as queries:
        found = available_robots_read(fleet)

    assert [robot.code for robot in found] == ["R-A-MOVING", "R-B-UNREACHABLE"]
    assert [_values(robot) for robot in found] == [_values(robot) for robot in expected]
    assert found[0].errors == ["LIDAR-DIRTY"]  # JSON, loaded as the ORM loads it
    assert all(robot.site is fleet for robot in found)
    assert len(queries) == 1


def test_an_available_robot_is_locked_and_one_kept_from_tasks_is_not_found(fleet):
    moving = Robot.objects.get(code="R-A-MOVING")
    with transaction.atomic(), CaptureQueriesContext(connection) as queries:
        locked = robot_lock_if_available(moving.pk, fleet)
        for code in KEPT_FROM_TASKS:
            assert robot_lock_if_available(Robot.objects.get(code=code).pk, fleet) is None

    assert _values(locked) == _values(moving)
    assert locked.site is fleet
    if connection.vendor == "postgresql":
        assert queries[0]["sql"].endswith("FOR NO KEY UPDATE")


def test_a_robot_of_another_site_is_not_found_there(fleet):
    elsewhere = Robot.objects.get(code="R-ELSEWHERE")

    assert available_robots_read(fleet, robot_id=elsewhere.pk) == []
