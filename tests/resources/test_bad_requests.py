"""Bad resource requests get 400 naming the field, and nothing of the heartbeat is applied."""

import copy

import pytest

from boards.models import BoardMessage, RobotEvent, RobotRequest
from resources.leases import lease_sweep
from resources.models import Lease
from tests import factories
from tests.resources.conftest import acquire, event, holders, release


@pytest.fixture
def holder(make_bot):
    """RA holds the door and has its grant on the board, unacked."""
    bot = make_bot("RA")
    bot.acquire("DOOR-2F")
    return bot


def snapshot(bot):
    bot.robot.refresh_from_db()
    return {
        "seq": bot.robot.seq,
        "status": bot.robot.status,
        "leases": list(Lease.objects.values_list("pk", "state", "request_id")),
        "requests": RobotRequest.objects.count(),
        "events": RobotEvent.objects.count(),
        "pending": list(BoardMessage.objects.pending().values_list("pk", flat=True)),
    }


def refused(bot, *, requests=(), events=()):
    """Post a heartbeat that also acks everything, moves the robot and releases the door."""
    pending = [f"m-{pk}" for pk in BoardMessage.objects.pending().values_list("pk", flat=True)]
    bot.seq += 1
    body = factories.heartbeat_body(
        bot.seq,
        state={"status": "moving", "floor": "1F", "waypoint": None},
        acks=pending,
        requests=[release("DOOR-2F"), *requests],
        events=[event("resource_entered", "DOOR-2F"), *events],
    )
    response = bot.http.post(body)
    assert response.status_code == 400, response.text
    assert response.json()["error"] == "invalid"
    return response.json()["detail"]


@pytest.mark.parametrize(
    ("request_", "field", "why"),
    [
        (acquire("NO-SUCH-LIFT"), "requests[1].resource", "unknown resource"),
        (release("NO-SUCH-LIFT"), "requests[1].resource", "unknown resource"),
        (release("CORR-3F"), "requests[1].resource", "holds no lease on CORR-3F"),
        (acquire("ELEV"), "requests[1].to_floor", "required to ride elevator ELEV"),
        (acquire("ELEV", to_floor="4F"), "requests[1].to_floor", "does not stop at 4F"),
        (acquire("ELEV", to_floor="9F"), "requests[1].to_floor", "unknown floor"),
    ],
)
def test_it_refuses_a_bad_request_naming_the_field_and_applies_nothing(
    holder, request_, field, why
):
    before = snapshot(holder)

    detail = refused(holder, requests=[copy.deepcopy(request_)])

    assert list(detail) == [field]
    assert why in detail[field][0]
    assert snapshot(holder) == before
    assert holders("DOOR-2F") == ["RA"]


def test_it_refuses_an_unknown_resource_in_an_event(holder):
    before = snapshot(holder)

    detail = refused(holder, events=[event("resource_released", "NO-SUCH-DOOR")])

    assert list(detail) == ["events[1].resource"]
    assert snapshot(holder) == before


def test_it_names_every_bad_request_of_a_heartbeat(holder):
    detail = refused(
        holder, requests=[acquire("ELEV"), release("CORR-3F"), acquire("ELEV", to_floor="4F")]
    )

    assert sorted(detail) == ["requests[1].to_floor", "requests[3].to_floor"]


def test_it_names_a_release_without_lease_after_the_floors_are_right(holder):
    detail = refused(holder, requests=[acquire("CORR-3F"), release("ELEV")])

    assert list(detail) == ["requests[2].resource"]
    assert not Lease.objects.filter(resource__code="CORR-3F").exists()


def test_it_applies_a_refused_heartbeat_sent_again_corrected(holder):
    bad = acquire("ELEV", id="q-fixed")
    refused(holder, requests=[bad])

    messages = holder.beat(requests=[{**bad, "to_floor": "2F"}])

    assert [m["request"] for m in messages if m["type"] == "resource_grant"] == [
        Lease.objects.get(resource__code="DOOR-2F").request_id,
        "q-fixed",
    ]


def test_it_accepts_a_release_after_the_server_ended_the_lease_and_changes_nothing(holder):
    door = Lease.objects.get()
    lease_sweep(now=door.expires_at)  # the grant expires as the robot decides to give up

    holder.release("DOOR-2F")

    door.refresh_from_db()
    assert (door.state, door.end_cause) == ("expired", "grant_timeout")
