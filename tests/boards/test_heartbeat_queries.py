"""The heartbeat is the hot path: its query count is asserted, not just measured."""

import pytest
from django.test import Client

from boards.services import board_post
from tests import factories


@pytest.fixture
def post_heartbeat(robot):
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


def test_it_answers_a_plain_heartbeat_in_five_queries(post_heartbeat, django_assert_num_queries):
    # savepoint (the heartbeat's transaction, inside the test's), find the robot by its token
    # and lock it, update it, read its board, release savepoint
    with django_assert_num_queries(5):
        post_heartbeat(factories.heartbeat_body(2))


def test_it_needs_four_more_queries_for_events_and_acks(
    post_heartbeat, robot, django_assert_num_queries
):
    message = board_post(robot=robot, type="action", body={"action": "pause"})
    body = factories.heartbeat_body(
        3, acks=[message.public_id], events=[{"id": f"e-{n}", "type": "arrived"} for n in range(20)]
    )

    # + find acked messages, mark them acked, find events seen before, insert new events
    with django_assert_num_queries(9):
        post_heartbeat(body)
