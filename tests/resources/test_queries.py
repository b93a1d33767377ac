"""The heartbeat is the hot path: the query count of an acquire is asserted, not just measured."""

import pytest
from django.test import Client
from django.utils import timezone

from building.models import Device
from tests import factories
from tests.factories import lease_acquire
from tests.resources.conftest import acquire, resource


@pytest.fixture
def post_heartbeat(robot, fleet_counted_once):
    client = Client()
    url = f"/api/v1/robots/{robot.code}/heartbeat"
    seq = iter(range(1, 100))

    def post(**fields):
        body = factories.heartbeat_body(next(seq), **fields)
        response = client.post(
            url, body, content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {robot.token}"
        )
        assert response.status_code == 200, response.content
        return response.json()["messages"]

    post()  # first contact: boot record, presence change, map cache
    return post


# A plain heartbeat takes 5 (savepoint, find and lock the robot, update it, read its board,
# release savepoint); a request adds 2 in boards (find requests seen before, insert the new one)
# and 4 here: lock the resource, read its live leases, insert the lease, insert its message.
ACQUIRE_QUERIES = 11
# A grant also reads the latest end recorded after its time (resources/leases.py: a grant is
# never recorded before it) and drives the lift (building/services.py): read its device, write
# its request.
GRANT_QUERIES = ACQUIRE_QUERIES + 3


@pytest.fixture
def lift(site):
    """The elevator's device, as the first grant of it creates it."""
    return Device.objects.create(
        resource=resource("ELEV"), reported_at=timezone.now(), state_since=timezone.now()
    )


def test_it_grants_an_acquire_in_fourteen_queries(post_heartbeat, lift, django_assert_num_queries):
    with django_assert_num_queries(GRANT_QUERIES):
        messages = post_heartbeat(requests=[acquire("ELEV", to_floor="2F")])

    assert [m["type"] for m in messages] == ["resource_grant"]


def test_it_queues_an_acquire_in_as_many(post_heartbeat, site, django_assert_num_queries):
    holder = factories.robot_create(site, "R2")
    lease_acquire(robot=holder, resource=resource("ELEV"), request_id="q-1", to_floor="3F")

    with django_assert_num_queries(ACQUIRE_QUERIES):
        messages = post_heartbeat(requests=[acquire("ELEV", to_floor="2F")])

    assert [m["type"] for m in messages] == ["resource_queued"]


def test_it_costs_a_heartbeat_without_resource_business_nothing_more(
    post_heartbeat, django_assert_num_queries
):
    # As tests/boards/test_heartbeat_queries.py's plain heartbeat: savepoint, find and lock the
    # robot, update it, read its board, commit without waiting for the disk, release savepoint.
    with django_assert_num_queries(6):
        post_heartbeat()
