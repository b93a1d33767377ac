"""What the reference client adds for robustness: refused items and delivery of an event."""

import pytest

from boards.models import RobotEvent
from robotsim.client import RefusedError, RobotClient


def make_client(live_server, robot):
    client = RobotClient(server_url=live_server.url, robot=robot.code, token=robot.token)
    client.update_state(status="idle", floor="1F", waypoint="1F-DOCK-1", battery=0.9)
    return client


def test_it_drops_only_the_items_a_400_names_so_later_heartbeats_get_through(live_server, robot):
    client = make_client(live_server, robot)
    good = client.event("arrived")
    bad = client.event("loaded", task="T-9999", stop=0)  # a task the server never heard of
    with pytest.raises(RefusedError) as refused:
        client.heartbeat()
    assert refused.value.status == 400
    assert refused.value.fields == ["events[1].task"]

    dropped = client.drop_refused(refused.value)

    assert [item["id"] for item in dropped] == [bad]
    assert client.heartbeat() == []
    assert list(RobotEvent.objects.values_list("event_id", flat=True)) == [good]


def test_it_knows_when_an_event_has_reached_the_server(live_server, robot):
    client = make_client(live_server, robot)
    entered = client.event("resource_entered", resource="ELEV")
    client.acquire("ELEV", to_floor="3F")  # the server needs a lease to record the entry

    assert not client.delivered(entered)
    client.heartbeat()

    assert client.delivered(entered)
