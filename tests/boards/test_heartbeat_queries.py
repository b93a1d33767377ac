"""The heartbeat is the hot path: its query count is asserted, not just measured."""

import psycopg
import pytest
from django.db import connection
from django.test import Client
from psycopg.pq import TransactionStatus

from boards.services import board_post
from core.pgtrace import PREPARED, round_trips
from tests import factories


@pytest.fixture
def post_heartbeat(robot, fleet_counted_once):
    client = Client()
    url = f"/api/v1/robots/{robot.code}/heartbeat"

    def post(body):
        response = client.post(
            url, body, content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {robot.token}"
        )
        assert response.status_code == 200, response.content
        return response.json()

    post(factories.heartbeat_body(1))  # first contact: boot record, presence change, map cache
    return post


def test_it_answers_a_plain_heartbeat_in_six_queries(post_heartbeat, django_assert_num_queries):
    # savepoint (the heartbeat's transaction, inside the test's), find the robot by its token
    # and lock it, update it, read its board, commit without waiting for the disk (it wrote
    # only its robot's row: core/commits.py), release savepoint
    with django_assert_num_queries(6) as queries:
        post_heartbeat(factories.heartbeat_body(2))

    assert queries.captured_queries[-2]["sql"] == "SET LOCAL synchronous_commit TO OFF"


def test_it_needs_three_more_queries_for_events_and_acks(
    post_heartbeat, robot, django_assert_num_queries
):
    message = board_post(robot=robot, type="action", body={"action": "pause"})
    body = factories.heartbeat_body(
        3, acks=[message.public_id], events=[{"id": f"e-{n}", "type": "arrived"} for n in range(20)]
    )

    # + mark the acked message acked if it is on the board (one UPDATE … RETURNING), find
    # events seen before, insert new events; and the commit waits for the disk, as it wrote
    # more than its robot's row
    with django_assert_num_queries(8) as queries:
        post_heartbeat(body)

    assert not [q for q in queries.captured_queries if "synchronous_commit" in q["sql"]]
    message.refresh_from_db()
    assert message.acked_at is not None


def test_a_heartbeat_that_moved_anything_else_commits_durably(
    post_heartbeat, robot, django_assert_max_num_queries
):
    """A robot reporting a fault is held and operators alerted in the heartbeat's
    transaction: that must reach the disk before the answer goes out."""
    state = {"status": "error", "errors": ["lidar blocked"]}
    with django_assert_max_num_queries(50) as queries:
        post_heartbeat(factories.heartbeat_body(4, state=state))

    robot.refresh_from_db()
    assert robot.fault_at is not None
    assert not [q for q in queries.captured_queries if "synchronous_commit" in q["sql"]]


# Outside a test's transaction, as a web worker serves it: the heartbeat's transaction is the
# outermost one, and a plain heartbeat sends its SET LOCAL and COMMIT in one round trip.


@pytest.fixture
def outermost(transactional_db, robot):
    """Heartbeats posted in no enclosing transaction; the first one already sent (its
    statements prepared)."""
    client = Client()
    url = f"/api/v1/robots/{robot.code}/heartbeat"

    def post(body):
        return client.post(
            url, body, content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {robot.token}"
        )

    assert post(factories.heartbeat_body(1)).status_code == 200
    return post


def test_a_plain_heartbeat_commits_relaxed_in_its_last_round_trip(outermost, robot):
    with round_trips() as sent:
        response = outermost(factories.heartbeat_body(2, state={"battery": 0.42}))

    assert response.status_code == 200
    # robot found by its token and locked, updated, its board read
    assert sent == ["BEGIN", *[PREPARED] * 3, "SET LOCAL synchronous_commit TO OFF; COMMIT"]
    assert connection.connection.info.transaction_status == TransactionStatus.IDLE
    assert _battery_seen_by_another_connection(robot) == 0.42


def test_a_heartbeat_that_wrote_more_commits_durably(outermost, robot):
    message = board_post(robot=robot, type="action", body={"action": "pause"})

    with round_trips() as sent:
        response = outermost(factories.heartbeat_body(2, acks=[message.public_id]))

    assert response.status_code == 200
    assert sent[-1] == "COMMIT"
    assert not [query for query in sent if "synchronous_commit" in query]
    message.refresh_from_db()
    assert message.acked_at is not None


def test_a_refused_heartbeat_commits_nothing(outermost, robot):
    body = factories.heartbeat_body(2, state={"battery": 0.42, "status": "flying"})

    with round_trips() as sent:
        response = outermost(body)

    assert response.status_code == 400
    assert "ROLLBACK" in sent  # then psycopg deallocates its prepared statements
    assert not [query for query in sent if "COMMIT" in query]
    assert _battery_seen_by_another_connection(robot) == 0.9


def _battery_seen_by_another_connection(robot) -> float:
    with psycopg.connect(**connection.get_connection_params()) as other:
        table = type(robot)._meta.db_table
        row = other.execute(f"SELECT battery FROM {table} WHERE id = %s", [robot.pk])
        return row.fetchone()[0]
