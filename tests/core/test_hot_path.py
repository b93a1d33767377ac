"""The hot path through public APIs: the heartbeat's locking lookup, its serializers (core/
serializers.py), and PostgreSQL preparing what runs often (Django's server_side_binding)."""

from types import SimpleNamespace

import pytest
from django.conf import settings
from django.db import connection, transaction
from django.test.utils import CaptureQueriesContext

from boards.serializers import HeartbeatSerializer
from boards.services import board_pending, board_post
from robots.mapcache import site_map
from robots.models import Robot
from robots.services import robot_authenticate
from tests import factories

pytestmark = pytest.mark.django_db


def test_the_locking_lookup_locks_the_robots_row(robot):
    with transaction.atomic(), CaptureQueriesContext(connection) as queries:
        found = robot_authenticate(token=robot.token, lock=True)

    assert found.pk == robot.pk
    assert found.site.code == robot.site.code
    assert robot_authenticate(token="not-a-token", lock=True) is None
    if connection.vendor == "postgresql":
        assert "FOR NO KEY UPDATE" in queries[0]["sql"]


def test_serializers_sharing_fields_each_validate_against_their_own_map(site):
    empty = SimpleNamespace(floors={}, waypoints={}, resources={})  # knows no code at all
    known = HeartbeatSerializer(
        data=factories.heartbeat_body(1), context={"site_map": site_map(site)}
    )
    assert known.is_valid(), known.errors

    unknown = HeartbeatSerializer(data=factories.heartbeat_body(2), context={"site_map": empty})
    assert not unknown.is_valid()
    assert "unknown" in str(unknown.errors["state"])

    again = HeartbeatSerializer(
        data=factories.heartbeat_body(3), context={"site_map": site_map(site)}
    )
    assert again.is_valid(), again.errors
    assert again.validated_data["seq"] == 3
    assert known.validated_data["seq"] == 1


def test_no_index_covers_what_every_heartbeat_rewrites():
    # An indexed column that changes turns the heartbeat's in-place (HOT) UPDATE into one that
    # writes an entry in every index of the table (robots/models/fleet.py).
    rewritten = {"last_seen_at", "unreachable_at", "offline_at", "reported_at", "seq"}
    with connection.cursor() as cursor:
        constraints = connection.introspection.get_constraints(cursor, Robot._meta.db_table)

    indexed = {column for c in constraints.values() if c["index"] for column in c["columns"]}

    assert indexed, "introspection found no index at all"
    assert not indexed & rewritten


def _prepared_statements() -> list[str]:
    with connection.cursor() as cursor:
        cursor.execute("SELECT statement FROM pg_prepared_statements")
        return [row[0] for row in cursor.fetchall()]


@pytest.mark.skipif(connection.vendor != "postgresql", reason="PostgreSQL prepares statements")
def test_on_postgresql_a_statement_run_often_is_prepared_once_per_connection(robot):
    board_post(robot=robot, type="action", body={"action": "pause"})
    other = factories.robot_create(robot.site, "R2")
    before = _prepared_statements()
    runs = settings.DATABASES["default"]["OPTIONS"]["prepare_threshold"] + 1

    mine = [board_pending(robot=robot) for _ in range(runs)]
    others = board_pending(robot=other)

    new = [sql for sql in _prepared_statements() if sql not in before]
    pending = [sql for sql in new if "boards_boardmessage" in sql]
    assert len(pending) == 1
    assert "$1" in pending[0]  # bound by the server
    assert all([m.body for m in each] == [{"action": "pause"}] for each in mine)
    assert others == []
