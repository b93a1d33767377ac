"""Protocol v1, "Resources": acquire, queue, enter and release over real HTTP heartbeats."""

from datetime import timedelta

import pytest

from resources.models import Lease
from robots.models import Alert
from tests.resources.conftest import (
    acquire,
    event,
    holders,
    lease_of,
    messages_about,
    of_type,
    release,
)


@pytest.fixture
def a(make_bot):
    return make_bot("RA")


@pytest.fixture
def b(make_bot):
    return make_bot("RB")


@pytest.fixture
def c(make_bot):
    return make_bot("RC")


def test_it_grants_a_free_elevator_at_once_and_records_the_ride(a):
    messages = a.acquire("ELEV", id="q-1", to_floor="3F")

    lease = lease_of(a, "ELEV")
    assert messages == [
        {
            "id": messages[0]["id"],
            "type": "resource_grant",
            "request": "q-1",
            "resource": "ELEV",
            "lease": f"L-{lease.pk}",
            "expires_at": lease.expires_at.isoformat(timespec="milliseconds").replace(
                "+00:00", "Z"
            ),
            "to_floor": "3F",
        }
    ]
    assert lease.state == "granted"
    assert (lease.from_floor.code, lease.to_floor.code) == ("1F", "3F")
    assert lease.expires_at - lease.granted_at == timedelta(seconds=60)
    assert lease.requested_at == lease.granted_at


def test_it_queues_later_robots_with_their_position(a, b, c):
    a.acquire("ELEV", to_floor="2F")

    b_messages = b.acquire("ELEV", id="q-b", to_floor="2F")
    c_messages = c.acquire("ELEV", to_floor="3F")

    assert [(m["type"], m["request"], m["resource"], m["position"]) for m in b_messages] == [
        ("resource_queued", "q-b", "ELEV", 1)
    ]
    assert [m["position"] for m in of_type(c_messages, "resource_queued")] == [2]
    assert holders("ELEV") == ["RA"]


def test_it_grants_the_next_in_line_as_soon_as_the_holder_releases(a, b, c):
    a.acquire("ELEV", to_floor="2F")
    b.acquire("ELEV", to_floor="2F")
    c.acquire("ELEV", to_floor="2F")
    a.entered("ELEV")

    a_messages = a.release("ELEV")

    b_messages = b.beat()
    assert of_type(a_messages, "resource_grant") == []  # its unacked grant is withdrawn
    assert [(m["type"], m["lease"]) for m in b_messages] == [
        ("resource_grant", lease_of(b, "ELEV").public_id)
    ]  # the grant replaced the unacked queued message
    assert of_type(c.beat(), "resource_queued")[0]["position"] == 2  # as told; not reposted
    assert holders("ELEV") == ["RB"]
    assert lease_of(a, "ELEV").state == "released"


def test_it_redelivers_a_grant_whose_responses_were_lost_until_it_is_acked(a):
    a.acquire("ELEV", to_floor="2F")  # the response never reaches the robot

    first = a.beat()
    second = a.beat()
    a.beat(acks=[first[0]["id"]])

    assert first == second
    assert first[0]["type"] == "resource_grant"
    assert a.beat() == []
    assert len(messages_about(lease_of(a, "ELEV"), "resource_grant")) == 1


def test_it_does_not_queue_a_robot_twice_for_a_repeated_acquire(a, b, c):
    a.acquire("ELEV", to_floor="2F")
    request = acquire("ELEV", id="q-b1", to_floor="2F")

    b.beat(requests=[request])
    b.beat(requests=[request, request])  # the same id again: applied once
    messages = b.beat(requests=[acquire("ELEV", id="q-b2", to_floor="3F")])  # a new id

    lease = Lease.objects.get(robot=b.robot)
    assert (lease.state, lease.request_id, lease.to_floor.code) == ("queued", "q-b2", "3F")
    assert [(m["type"], m["request"], m["position"]) for m in messages] == [
        ("resource_queued", "q-b2", 1)
    ]
    assert of_type(c.acquire("ELEV", to_floor="2F"), "resource_queued")[0]["position"] == 2


def test_it_answers_a_new_acquire_of_the_holder_with_its_grant_again(a):
    first = a.acquire("ELEV", id="q-1", to_floor="2F")

    again = a.acquire("ELEV", id="q-2", to_floor="2F")

    assert Lease.objects.filter(robot=a.robot).count() == 1
    assert [(m["type"], m["request"], m["lease"]) for m in again] == [
        ("resource_grant", "q-2", first[0]["lease"])
    ]


def test_it_records_entering_and_hands_over_on_the_released_event(a, b):
    a.acquire("ELEV", to_floor="2F")
    b.acquire("ELEV", to_floor="2F")

    a.entered("ELEV")
    entered = lease_of(a, "ELEV")
    a.left("ELEV")

    assert entered.state == "entered"
    assert entered.entered_at is not None
    ended = lease_of(a, "ELEV")
    assert (ended.state, ended.end_cause) == ("released", "released_event")
    assert of_type(b.beat(), "resource_grant")


def test_it_accepts_a_release_request_and_a_released_event_for_one_leave(a, b):
    a.acquire("ELEV", to_floor="2F")
    b.acquire("ELEV", to_floor="2F")
    a.entered("ELEV")

    a.beat(requests=[release("ELEV")], events=[event("resource_released", "ELEV")])
    a.release("ELEV")  # late duplicate of the leave, under a new request id

    assert lease_of(a, "ELEV").end_cause == "released_event"  # events are applied first
    assert Lease.objects.filter(robot=a.robot).count() == 1
    assert holders("ELEV") == ["RB"]
    assert len(messages_about(lease_of(b, "ELEV"), "resource_grant")) == 1


def test_it_skips_a_robot_that_left_the_queue(a, b, c):
    a.acquire("DOOR-2F")
    b.acquire("DOOR-2F")
    c.acquire("DOOR-2F")

    b_messages = b.release("DOOR-2F")
    a.release("DOOR-2F")

    assert b_messages == []  # its queued message is withdrawn
    assert lease_of(b, "DOOR-2F").state == "released"
    assert holders("DOOR-2F") == ["RC"]


def test_it_lets_one_robot_through_a_door_and_two_into_a_corridor(a, b, c):
    a.acquire("DOOR-2F")
    door_b = b.acquire("DOOR-2F")
    a.acquire("CORR-3F")
    corridor_b = b.acquire("CORR-3F")
    corridor_c = c.acquire("CORR-3F")

    assert of_type(door_b, "resource_queued")[0]["position"] == 1
    assert of_type(corridor_b, "resource_grant")[0]["resource"] == "CORR-3F"
    assert "to_floor" not in of_type(corridor_b, "resource_grant")[0]
    assert of_type(corridor_c, "resource_queued")[0]["position"] == 1
    assert (holders("DOOR-2F"), holders("CORR-3F")) == (["RA"], ["RA", "RB"])

    b.release("CORR-3F")

    assert holders("CORR-3F") == ["RA", "RC"]
    assert of_type(c.beat(), "resource_grant")[0]["resource"] == "CORR-3F"


def test_it_records_and_alerts_entering_without_a_grant_instead_of_refusing_it(a, b, c):
    a.acquire("ELEV", to_floor="2F")
    c.acquire("ELEV", to_floor="2F")

    b.entered("ELEV")  # never asked

    rogue = lease_of(b, "ELEV")
    assert (rogue.state, rogue.granted_at, rogue.request_id) == ("entered", None, "")
    alert = Alert.objects.open().get()
    assert (alert.kind, alert.robot.code, alert.resource.code) == (
        "entered_without_grant",
        "RB",
        "ELEV",
    )
    assert holders("ELEV") == ["RA", "RB"]

    a.release("ELEV")
    assert lease_of(c, "ELEV").state == "queued"  # RB is still inside
    b.left("ELEV")
    assert holders("ELEV") == ["RC"]


def test_it_alerts_when_a_queued_robot_enters_anyway(a, b):
    a.acquire("DOOR-2F")
    b.acquire("DOOR-2F")

    messages = b.entered("DOOR-2F")

    assert of_type(messages, "resource_queued") == []
    assert lease_of(b, "DOOR-2F").state == "entered"
    assert Alert.objects.open().get().kind == "entered_without_grant"


def test_it_publishes_every_lease_change_for_the_live_pages(a, b, monkeypatch):
    published = []
    monkeypatch.setattr("ui.live.publish.publish_on_commit", lambda **push: published.append(push))

    a.acquire("ELEV", to_floor="2F")
    b.acquire("ELEV", to_floor="2F")
    a.release("ELEV")

    leases = [p for p in published if p["kind"] == "lease"]  # robots' state goes there too
    assert [(p["kind"], p["data"]["robot"], p["data"]["state"]) for p in leases] == [
        ("lease", "RA", "granted"),
        ("lease", "RB", "queued"),
        ("lease", "RA", "released"),
        ("lease", "RB", "granted"),
    ]
    assert leases[0]["data"]["id"] == lease_of(a, "ELEV").public_id
