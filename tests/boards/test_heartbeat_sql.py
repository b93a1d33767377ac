"""The heartbeat's plain SQL (boards/heartbeat_sql.py) gives what the ORM's querysets give."""

import pytest
from django.db import connection, transaction
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from boards.heartbeat_sql import board_message_ack, board_pending_of, robot_by_token_locked
from boards.models import BoardMessage
from boards.services import board_post, board_withdraw
from robots.models import Robot
from tests import factories

pytestmark = pytest.mark.django_db


def _values(instance) -> dict:
    return {f.attname: getattr(instance, f.attname) for f in instance._meta.concrete_fields}


def test_the_robot_found_by_its_token_is_the_one_the_orm_finds_with_its_site(robot):
    robot.errors, robot.battery, robot.last_seen_at = ["E-STOP"], 0.42, timezone.now()
    robot.compartments = [{"code": "A", "lockable": True}]
    robot.save()
    expected = Robot.objects.select_related("site").get(pk=robot.pk)

    with transaction.atomic(), CaptureQueriesContext(connection) as queries:
        found = robot_by_token_locked(robot.token)

    assert _values(found) == _values(expected)
    assert _values(found.site) == _values(expected.site)
    assert found.errors == ["E-STOP"]  # JSON, loaded as the ORM loads it
    assert len(queries) == 1
    if connection.vendor == "postgresql":
        assert "FOR NO KEY UPDATE OF r" in queries[0]["sql"]


def test_an_unknown_token_finds_no_robot(robot):
    with transaction.atomic():
        assert robot_by_token_locked("not-a-token") is None


def test_the_board_is_what_the_orm_finds_pending_oldest_first(robot, site):
    other = factories.robot_create(site, "R2")
    first = board_post(robot=robot, type="action", body={"action": "pause"})
    acked = board_post(robot=robot, type="action", body={"action": "resume"})
    BoardMessage.objects.filter(pk=acked.pk).update(acked_at=timezone.now())
    board_post(robot=other, type="action", body={"action": "pause"})
    last = board_post(robot=robot, type="plan", body={"version": 2, "tasks": {}})
    expected = list(BoardMessage.objects.pending().filter(robot=robot).order_by("id"))

    found = board_pending_of(robot.pk)

    assert [m.pk for m in found] == [first.pk, last.pk]
    assert [_values(m) for m in found] == [_values(m) for m in expected]
    assert board_pending_of(factories.robot_create(site, "R3").pk) == []


def test_an_ack_takes_the_robots_pending_message_off_its_board_and_no_other(robot, site):
    other = factories.robot_create(site, "R2")
    plan = board_post(robot=robot, type="plan", body={"version": 2, "tasks": {}})
    withdrawn = board_post(robot=robot, type="action", body={"action": "pause"})
    board_withdraw(messages=[withdrawn], reason="superseded")
    elsewhere = board_post(robot=other, type="action", body={"action": "pause"})
    now = timezone.now()

    with CaptureQueriesContext(connection) as queries:
        acked = board_message_ack(robot.pk, plan.pk, now)

    assert _values(acked) == _values(BoardMessage.objects.get(pk=plan.pk))
    assert acked.acked_at == now
    assert acked.body == {"version": 2, "tasks": {}}
    assert len(queries) == (1 if connection.vendor == "postgresql" else 2)
    assert board_message_ack(robot.pk, plan.pk, timezone.now()) is None  # acked already
    assert board_message_ack(robot.pk, withdrawn.pk, now) is None
    assert board_message_ack(robot.pk, elsewhere.pk, now) is None
    assert BoardMessage.objects.get(pk=plan.pk).acked_at == now
    assert BoardMessage.objects.filter(acked_at__isnull=False).count() == 1
