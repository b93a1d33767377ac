"""The heartbeat is the hot path: its query count is asserted, not just measured."""

import pytest
from django.test import Client

from boards.services import board_post
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


def test_it_needs_four_more_queries_for_events_and_acks(
    post_heartbeat, robot, django_assert_num_queries
):
    message = board_post(robot=robot, type="action", body={"action": "pause"})
    body = factories.heartbeat_body(
        3, acks=[message.public_id], events=[{"id": f"e-{n}", "type": "arrived"} for n in range(20)]
    )

    # + find acked messages, mark them acked, find events seen before, insert new events; and
    # the commit waits for the disk, as it wrote more than its robot's row
    with django_assert_num_queries(9) as queries:
        post_heartbeat(body)

    assert not [q for q in queries.captured_queries if "synchronous_commit" in q["sql"]]


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
