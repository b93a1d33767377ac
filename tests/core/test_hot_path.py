"""The hot path's shortcuts (core/statements.py, core/serializers.py) give what the ORM and DRF
give without them."""

import copy
from types import SimpleNamespace

import pytest
from django.db import DatabaseError, connection, transaction
from django.db.models import signals
from django.db.models.functions import Now
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from boards.models import BoardMessage, RobotEvent
from boards.serializers import HeartbeatSerializer
from boards.services import board_pending, board_post
from core.statements import (
    VALUES_ROWS,
    Statement,
    row_claim,
    row_insert,
    row_update,
    rows_insert,
    rows_update,
    values_stored,
)
from robots.mapcache import site_map
from robots.models import Robot
from robots.services import robot_authenticate
from tests import factories

pytestmark = pytest.mark.django_db


def test_a_statement_finds_what_the_orm_finds_with_each_calls_values(site):
    first, second = factories.robot_create(site, "R1"), factories.robot_create(site, "R2")
    by_code = Statement(
        lambda code: Robot.objects.filter(code=code).select_related("site"), code=str
    )

    found = [by_code.first(code="R2"), by_code.first(code="R1"), by_code.first(code="R9")]

    assert [robot and robot.pk for robot in found] == [second.pk, first.pk, None]
    assert found[0].site == site
    assert found[0].site.map_version == site.map_version
    assert found[0].battery == Robot.objects.get(pk=second.pk).battery
    assert found[0].errors == Robot.objects.get(pk=second.pk).errors  # converters applied


def test_a_statement_takes_floats_and_finds_what_the_orm_finds(site):
    robots = [factories.robot_create(site, f"R{n}") for n in range(1, 4)]
    for robot, battery in zip(robots, (0.2, 0.5, 0.8), strict=True):
        Robot.objects.filter(pk=robot.pk).update(battery=battery)
    charged = Statement(
        lambda site_id, least: Robot.objects.filter(site_id=site_id, battery__gte=least).order_by(
            "code"
        ),
        site_id=int,
        least=float,
    )

    for least in (0.1, 0.5, 0.79, 0.9):
        orm = Robot.objects.filter(site_id=site.pk, battery__gte=least).order_by("code")
        found = charged.all(site_id=site.pk, least=least)
        assert [r.code for r in found] == [r.code for r in orm]


def test_a_statement_runs_through_the_connection_as_any_query(robot):
    board_post(robot=robot, type="action", body={"action": "pause"})

    with CaptureQueriesContext(connection) as queries:
        assert [m.body for m in board_pending(robot=robot)] == [{"action": "pause"}]
        assert [m.body for m in board_pending(robot=robot)] == [{"action": "pause"}]

    assert len(queries) == 2
    assert queries[0]["sql"] == queries[1]["sql"]
    assert str(robot.pk) in queries[1]["sql"]


def test_a_value_the_sql_does_not_carry_is_refused_at_the_first_call(site):
    ignores_code = Statement(lambda code: Robot.objects.all(), code=str)

    with pytest.raises(TypeError, match="code"):
        ignores_code.all(code="R1")


def test_the_locking_lookup_locks_the_robots_row(robot):
    with transaction.atomic(), CaptureQueriesContext(connection) as queries:
        found = robot_authenticate(token=robot.token, lock=True)

    assert found.pk == robot.pk
    assert found.site.code == robot.site.code
    assert robot_authenticate(token="not-a-token", lock=True) is None
    if connection.vendor == "postgresql":
        assert "FOR NO KEY UPDATE" in queries[0]["sql"]


def test_row_update_writes_what_save_would_and_only_those_fields(robot):
    now = timezone.now()
    robot.battery, robot.errors, robot.last_seen_at = 0.42, ["E-STOP"], now
    robot.name = "not written"

    row_update(robot, ["battery", "errors", "last_seen_at"])

    stored = Robot.objects.get(pk=robot.pk)
    assert (stored.battery, stored.errors, stored.last_seen_at) == (0.42, ["E-STOP"], now)
    assert stored.name != "not written"


def test_row_update_of_a_row_that_is_not_there_fails_as_save_does(robot):
    gone = copy.copy(robot)
    gone.pk = robot.pk + 1000

    with pytest.raises(DatabaseError, match="did not affect any rows"):
        row_update(gone, ["battery"])


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
def test_on_postgresql_the_hot_statements_are_prepared_once_per_connection(robot):
    board_post(robot=robot, type="action", body={"action": "pause"})
    other = factories.robot_create(robot.site, "R2")
    before = _prepared_statements()

    mine, others = board_pending(robot=robot), board_pending(robot=other)
    again = board_pending(robot=robot)

    new = [sql for sql in _prepared_statements() if sql not in before]
    assert len(new) == 1
    assert "boards_boardmessage" in new[0]
    assert "$1" in new[0]  # bound by the server
    assert [m.body for m in mine] == [m.body for m in again] == [{"action": "pause"}]
    assert others == []


@pytest.mark.skipif(connection.vendor != "postgresql", reason="PostgreSQL prepares statements")
def test_prepared_statements_can_be_turned_off_for_a_connection_pooler(robot, settings):
    settings.DATABASE_PREPARED_STATEMENTS = False
    board_post(robot=robot, type="action", body={"action": "pause"})
    before = _prepared_statements()

    assert [m.body for m in board_pending(robot=robot)] == [{"action": "pause"}]
    assert [m.body for m in board_pending(robot=robot)] == [{"action": "pause"}]

    assert _prepared_statements() == before


def test_a_claim_writes_only_while_the_row_holds_what_it_expects(robot):
    other = copy.copy(robot)
    robot.battery, robot.errors = 0.42, ["E-STOP"]

    assert row_claim(robot, ["battery", "errors"], code=robot.code, dock=None) is False  # a dock
    assert row_claim(robot, ["battery", "errors"], code="R-ELSE") is False
    assert Robot.objects.get(pk=robot.pk).battery != 0.42
    assert row_claim(robot, ["battery", "errors"], code=robot.code) is True

    stored = Robot.objects.get(pk=robot.pk)
    assert (stored.battery, stored.errors) == (0.42, ["E-STOP"])
    other.battery = 0.9  # expects the code it had: still true, so it writes too
    assert row_claim(other, ["battery"], code=robot.code) is True
    assert Robot.objects.get(pk=robot.pk).battery == 0.9


def test_rows_update_writes_what_bulk_update_would_in_one_statement(site):
    robots = [factories.robot_create(site, f"R{n}") for n in range(1, 4)]
    now = timezone.now()
    for n, robot in enumerate(robots):
        robot.battery, robot.last_seen_at, robot.errors = n / 10, now if n else None, [f"E{n}"]
        robot.name = "not written"

    with CaptureQueriesContext(connection) as queries:
        rows_update(robots[:2], ["battery", "last_seen_at", "errors"])
        rows_update([], ["battery"])

    assert len(queries.captured_queries) == 1
    stored = {r.code: r for r in Robot.objects.all()}
    assert [(stored[r.code].battery, stored[r.code].last_seen_at) for r in robots[:2]] == [
        (0.0, None),
        (0.1, now),
    ]
    assert [stored[r.code].errors for r in robots[:2]] == [["E0"], ["E1"]]
    assert stored["R3"].battery != 0.2  # not among those written
    assert "not written" not in {r.name for r in stored.values()}


def _events(robot, at, *ids):
    """RobotEvents as a heartbeat builds them: a JSON body, values left null and blank."""
    return [
        RobotEvent(
            robot=robot,
            event_id=event_id,
            type="loaded",
            at=at if n else None,
            task="T-1" if n else "",
            stop=n or None,
            data={"nested": [n, None, "ü"], "text": 'a "quoted" value'},
            received_at=at,
            boot_id="b",
            seq=2**40 + n,
        )
        for n, event_id in enumerate(ids)
    ]


def _stored(event_ids):
    """The events' rows as stored, without their keys."""
    rows = RobotEvent.objects.filter(event_id__in=event_ids).order_by("event_id")
    return [{k: v for k, v in row.items() if k != "id"} for row in rows.values()]


@pytest.mark.parametrize("count", [1, 3, VALUES_ROWS + 2], ids=["one", "values", "arrays"])
def test_rows_insert_writes_what_bulk_create_would_in_one_statement(robot, count):
    """Up to VALUES_ROWS rows go as VALUES rows, more as arrays: the same rows either way, and
    the same prepared (values bound on the server) as when queries are logged (bound here)."""
    at = timezone.now()
    mine, theirs = [f"a{n:02d}" for n in range(count)], [f"b{n:02d}" for n in range(count)]
    ours, django = _events(robot, at, *mine), _events(robot, at, *theirs)
    prepared = [f"c{n:02d}" for n in range(count)]

    with CaptureQueriesContext(connection) as queries:
        inserted = rows_insert(ours)
        assert rows_insert([]) == []
    RobotEvent.objects.bulk_create(django)
    rows_insert(_events(robot, at, *prepared))  # queries not logged: prepared

    assert len(queries.captured_queries) == 1
    assert ("UNNEST" in queries.captured_queries[0]["sql"]) == (count > VALUES_ROWS)
    assert inserted == ours
    assert [event.pk for event in ours] == sorted(event.pk for event in ours)
    assert all(event.pk and not event._state.adding for event in ours)
    assert [RobotEvent.objects.get(pk=e.pk).event_id for e in ours] == mine
    for written in (mine, prepared):
        renamed = [{**row, "event_id": "b" + row["event_id"][1:]} for row in _stored(written)]
        assert renamed == _stored(theirs)


def test_rows_insert_with_an_expression_for_a_value_is_bulk_create(robot):
    event = _events(robot, timezone.now(), "e0")[0]
    event.received_at = Now()

    rows_insert([event])

    stored = RobotEvent.objects.get(event_id="e0")
    assert abs(stored.received_at - timezone.now()).total_seconds() < 60


def test_row_insert_is_create_with_the_receivers_create_would_call(robot):
    heard = []

    def receiver(sender, instance, created, **kwargs):
        heard.append((instance.pk, created))

    quiet = row_insert(BoardMessage(robot=robot, type="action", body={"action": "pause"}))
    signals.post_save.connect(receiver, sender=BoardMessage)
    try:
        told = row_insert(BoardMessage(robot=robot, type="action", body={"action": "resume"}))
    finally:
        signals.post_save.disconnect(receiver, sender=BoardMessage)

    assert heard == [(told.pk, True)]
    stored = {m.pk: m.body for m in BoardMessage.objects.filter(robot=robot)}
    assert stored == {quiet.pk: {"action": "pause"}, told.pk: {"action": "resume"}}


def test_values_stored_are_what_the_queryset_finds_in_one_statement(site, robot):
    other = factories.robot_create(site, "R2")
    at = timezone.now()
    rows_insert(_events(robot, at, "x0", "x1") + _events(other, at, "x2"))
    asked = ["x0", "x2", "x9", "x1", "x0"]

    with CaptureQueriesContext(connection) as queries:
        found = values_stored(RobotEvent, "event_id", asked, robot_id=robot.pk)
        assert values_stored(RobotEvent, "event_id", [], robot_id=robot.pk) == set()

    assert found == {"x0", "x1"}
    orm = RobotEvent.objects.filter(robot_id=robot.pk, event_id__in=asked)
    assert found == set(orm.values_list("event_id", flat=True))
    assert len(queries.captured_queries) == 1
