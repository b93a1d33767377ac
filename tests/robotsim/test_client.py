"""The reference robot client against the live server, over real HTTP."""

import json
import threading

import pytest

from boards.models import RobotEvent
from boards.services import board_post
from robotsim.client import (
    HttpTransport,
    RefusedError,
    RobotClient,
    TransportError,
    listen_for_wakes,
)
from tests import factories


class FlakyTransport(HttpTransport):
    """Drops chosen requests before they leave, or responses after the server answered."""

    def __init__(self):
        super().__init__(timeout=10)
        self.drop_request = False
        self.drop_response = False

    def post(self, url, body, headers):
        if self.drop_request:
            raise TransportError("request lost")
        answer = super().post(url, body, headers)
        if self.drop_response:
            raise TransportError("response lost")
        return answer


@pytest.fixture
def transport():
    return FlakyTransport()


@pytest.fixture
def client(live_server, robot, transport):
    client = RobotClient(
        server_url=live_server.url, robot=robot.code, token=robot.token, transport=transport
    )
    client.update_state(status="idle", floor="1F", waypoint="1F-DOCK-1", battery=0.9)
    return client


def test_it_keeps_events_until_a_heartbeat_carrying_them_is_answered(client, transport):
    client.event("arrived")
    transport.drop_request = True
    assert client.heartbeat() is None
    transport.drop_request, transport.drop_response = False, True
    assert client.heartbeat() is None  # the server applied it, but the robot cannot know
    transport.drop_response = False

    assert client.heartbeat() == []

    assert client.unsent == 0
    assert RobotEvent.objects.count() == 1


def test_it_applies_each_message_once_and_acks_it(client, robot, transport):
    message = board_post(robot=robot, type="action", body={"action": "pause"})
    applied = []
    client.on("action", applied.append)

    transport.drop_response = True
    client.heartbeat()  # lost answer: the message comes again
    transport.drop_response = False
    first = client.heartbeat()
    second = client.heartbeat()  # carries the ack
    third = client.heartbeat()

    assert [m["id"] for m in first] == [message.public_id]
    assert second == []
    assert third == []
    assert len(applied) == 1
    message.refresh_from_db()
    assert message.acked_at is not None


def test_it_applies_only_newer_plans(client, robot):
    followed = []
    client.on("plan", lambda plan: followed.append(plan["plan_version"]))
    for version in (2, 1, 3, 3):
        board_post(robot=robot, type="plan", body={"plan_version": version, "stops": []})

    client.heartbeat()

    assert followed == [2, 3]
    assert client.plan_version == 3


def test_it_reports_the_applied_plan_version_and_state(client, robot):
    board_post(robot=robot, type="plan", body={"plan_version": 5, "stops": []})
    client.heartbeat()
    client.update_state(status="moving", battery=0.5)

    client.heartbeat()

    robot.refresh_from_db()
    assert (robot.plan_version, robot.status, robot.battery) == (5, "moving", 0.5)


def test_it_raises_when_the_server_refuses(live_server, robot):
    client = RobotClient(server_url=live_server.url, robot=robot.code, token="wrong")

    with pytest.raises(RefusedError) as refused:
        client.heartbeat()

    assert refused.value.status == 401


def test_its_loop_heartbeats_until_stopped(client, robot):
    stop = threading.Event()
    client.heartbeat_interval = 0.05
    beats = []
    original = client.heartbeat

    def counting():
        beats.append(1)
        if len(beats) >= 3:
            stop.set()
        return original()

    client.heartbeat = counting
    client.run(stop=stop)

    robot.refresh_from_db()
    assert robot.seq == 3


def test_it_says_push_while_its_push_channel_is_open_and_is_told_the_idle_interval(
    client, robot, settings, monkeypatch
):
    """Idle with the channel open, the robot is told the idle interval; when the channel closes
    it is woken at once, and its next heartbeat, without `push`, is told the site's."""
    from websockets.exceptions import ConnectionClosedError

    settings.HEARTBEAT_IDLE_INTERVAL = 5
    stop, told = threading.Event(), []

    class Socket:  # the push channel: open until the robot has heartbeated once, then closed
        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def recv(self, timeout):
            client.heartbeat()
            told.append(client.heartbeat_interval)
            stop.set()
            raise ConnectionClosedError(None, None)

    monkeypatch.setattr("websockets.sync.client.connect", lambda url, **kwargs: Socket())
    listen_for_wakes(client, ws_url="ws://push.invalid", token=robot.token, stop=stop)

    assert told == [factories.interval_told(robot, 5.0)]  # spread over robots: 2.5 to 7.5 s
    assert client.wake.is_set()
    assert not client.push_open
    client.heartbeat()
    assert client.heartbeat_interval == 1.0


def test_the_heartbeat_a_wake_caused_says_so_and_no_other(client, robot, transport, monkeypatch):
    """`Woken-By` names the wake's message on the one heartbeat that wake caused (the proxy
    answers it ahead of the regular heartbeats); the wake after a (re)connection names none."""
    headers_sent, post = [], transport.post

    def recording(url, body, headers):
        headers_sent.append(headers.get("Woken-By"))
        return post(url, body, headers)

    monkeypatch.setattr(transport, "post", recording)
    stop, posted = threading.Event(), []

    class Socket:  # the push channel: the connection's own wake, one posted message's, stop
        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def recv(self, timeout):
            if posted:
                stop.set()
                raise TimeoutError
            client.heartbeat()  # the one the connection's wake asks for
            posted.append(board_post(robot=robot, type="action", body={"action": "pause"}))
            return json.dumps({"type": "wake", "message": posted[0].public_id})

    monkeypatch.setattr("websockets.sync.client.connect", lambda url, **kwargs: Socket())
    listen_for_wakes(client, ws_url="ws://push.invalid", token=robot.token, stop=stop)
    answered = client.heartbeat()
    client.heartbeat()

    assert headers_sent == [None, posted[0].public_id, None]
    assert [m["id"] for m in answered] == [posted[0].public_id]
