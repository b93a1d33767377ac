"""core/plainsql.py writes a row as the ORM's save(update_fields=...) writes it."""

from datetime import timedelta

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from core.plainsql import row_update
from robots.choices import Presence, RobotStatus
from robots.models import Robot
from robots.services import _HEARTBEAT_STATE_FIELDS
from tests import factories

pytestmark = pytest.mark.django_db


def _values(instance) -> dict:
    return {f.attname: getattr(instance, f.attname) for f in instance._meta.concrete_fields}


def _heartbeat_state(robot: Robot, site, now) -> None:
    robot.presence, robot.status = Presence.ONLINE, RobotStatus.MOVING
    robot.last_seen_at, robot.unreachable_at = now, now + timedelta(seconds=3)
    robot.offline_at, robot.heartbeat_interval_told = now + timedelta(minutes=5), 2.5
    robot.floor = site.floors.first()
    robot.waypoint = robot.floor.waypoints.first()
    robot.x, robot.y, robot.heading, robot.battery = 12.5, -3.25, 1.5, 0.77
    robot.load, robot.plan_version, robot.errors = 2, 7, ["LIDAR-DIRTY"]
    robot.boot_id, robot.seq = "boot-2", 41


def test_the_heartbeat_fields_are_written_as_save_writes_them(site):
    by_orm, by_sql = factories.robot_create(site, "R1"), factories.robot_create(site, "R2")
    now = timezone.now()
    for robot in (by_orm, by_sql):
        _heartbeat_state(robot, site, now)

    by_orm.save(update_fields=_HEARTBEAT_STATE_FIELDS)
    with CaptureQueriesContext(connection) as queries:
        row_update(by_sql, _HEARTBEAT_STATE_FIELDS)

    stored_orm = _values(Robot.objects.get(pk=by_orm.pk))
    stored_sql = _values(Robot.objects.get(pk=by_sql.pk))
    differing = {"id", "code", "name", "token_hash", "token_issued_at"}
    assert {k: v for k, v in stored_sql.items() if k not in differing} == {
        k: v for k, v in stored_orm.items() if k not in differing
    }
    assert stored_sql["errors"] == ["LIDAR-DIRTY"]
    assert stored_sql["waypoint_id"] == by_sql.waypoint_id is not None
    assert len(queries) == 1
    assert queries[0]["sql"].startswith(f'UPDATE "{Robot._meta.db_table}" SET')


def test_only_the_named_fields_and_only_its_row_are_written(site):
    robot, other = factories.robot_create(site, "R1"), factories.robot_create(site, "R2")
    before_other = _values(Robot.objects.get(pk=other.pk))
    robot.battery, robot.name = 0.5, "renamed in memory only"

    row_update(robot, ("battery",))

    stored = Robot.objects.get(pk=robot.pk)
    assert stored.battery == 0.5
    assert stored.name != "renamed in memory only"
    assert _values(Robot.objects.get(pk=other.pk)) == before_other
