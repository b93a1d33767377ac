"""Protocol v1: board redelivery, acks, exactly-once events and heartbeat ordering, over HTTP."""

import json
import threading

import pytest

from boards.hooks import heartbeat_applied
from boards.models import BoardMessage, RobotEvent, RobotRequest
from boards.services import board_post, board_withdraw
from robots.models import Robot
from tests import factories


@pytest.fixture
def applied_events():
    """Every event id handed to heartbeat_applied receivers, in order, whatever the thread."""
    seen, lock = [], threading.Lock()

    def receiver(*, applied):
        with lock:
            seen.extend(event.event_id for event in applied.events)

    with heartbeat_applied.watched_by(receiver):
        yield seen


def post_action(robot, action="pause"):
    return board_post(robot=robot, type="action", body={"action": action})


def message_ids(reply):
    return [message["id"] for message in reply["messages"]]


def test_it_redelivers_a_message_in_every_response_until_acked(robot_http, robot):
    message = post_action(robot)

    first = robot_http.heartbeat(1)
    second = robot_http.heartbeat(2)
    acking = robot_http.heartbeat(3, acks=[message.public_id])
    after = robot_http.heartbeat(4)

    assert first["messages"] == [{"id": message.public_id, "type": "action", "action": "pause"}]
    assert message_ids(second) == [message.public_id]
    assert message_ids(acking) == []
    assert message_ids(after) == []
    message.refresh_from_db()
    assert message.acked_at is not None


def test_it_sends_pending_messages_oldest_first(robot_http, robot):
    posted = [post_action(robot, action) for action in ("pause", "resume", "return_to_dock")]

    reply = robot_http.heartbeat(1, acks=[posted[1].public_id])

    assert message_ids(reply) == [posted[0].public_id, posted[2].public_id]


def test_it_does_not_send_withdrawn_messages(robot_http, robot):
    kept, withdrawn = post_action(robot), post_action(robot, "resume")
    board_withdraw(messages=[withdrawn], reason="test")

    assert message_ids(robot_http.heartbeat(1)) == [kept.public_id]


def test_it_supersedes_an_unacked_message_with_the_same_key(robot_http, robot):
    old = board_post(robot=robot, type="action", body={"action": "pause"}, key="k")
    new = board_post(robot=robot, type="action", body={"action": "resume"}, key="k", supersede=True)

    assert message_ids(robot_http.heartbeat(1)) == [new.public_id]
    old.refresh_from_db()
    assert old.withdraw_reason == "superseded"


def test_it_ignores_acks_of_unknown_withdrawn_or_foreign_messages(robot_http, robot, site):
    other_robot = factories.robot_create(site, "R2")
    foreign = post_action(other_robot)
    withdrawn = post_action(robot)
    board_withdraw(messages=[withdrawn], reason="test")

    reply = robot_http.heartbeat(
        1, acks=["m-999999", "nonsense", foreign.public_id, withdrawn.public_id]
    )

    assert reply["messages"] == []
    foreign.refresh_from_db()
    assert foreign.acked_at is None


@pytest.mark.parametrize("which", ["unknown", "nonsense", "foreign", "withdrawn", "acked"])
def test_it_ignores_a_lone_ack_of_a_message_not_on_its_board(robot_http, robot, site, which):
    """A lone ack (nearly every ack) takes its own path (boards.services._ack_one)."""
    foreign = post_action(factories.robot_create(site, "R2"))
    withdrawn, acked, pending = post_action(robot), post_action(robot), post_action(robot)
    board_withdraw(messages=[withdrawn], reason="test")
    robot_http.heartbeat(1, acks=[acked.public_id])
    ack = {
        "unknown": "m-999999",
        "nonsense": "nonsense",
        "foreign": foreign.public_id,
        "withdrawn": withdrawn.public_id,
        "acked": acked.public_id,
    }[which]
    acked_at = BoardMessage.objects.get(pk=acked.pk).acked_at

    reply = robot_http.heartbeat(2, acks=[ack])

    assert [m["id"] for m in reply["messages"]] == [pending.public_id]
    assert BoardMessage.objects.get(pk=acked.pk).acked_at == acked_at  # not acked again
    assert BoardMessage.objects.filter(acked_at__isnull=False).count() == 1


@pytest.mark.parametrize("accept", ["text/html", "application/xml", "*/*"])
def test_it_answers_json_whatever_the_robot_accepts(robot_http, robot, accept):
    message = post_action(robot)

    response = robot_http.post(factories.heartbeat_body(1), headers={"Accept": accept})

    assert response.status_code == 200
    assert response.headers["Content-Type"] == "application/json"
    assert [m["id"] for m in response.json()["messages"]] == [message.public_id]


def test_it_applies_each_event_once_under_duplicate_heartbeats(robot_http, robot, applied_events):
    events = [{"id": "e-1", "type": "arrived"}, {"id": "e-2", "type": "arrived"}]
    body = factories.heartbeat_body(1, events=events)

    for _ in range(3):
        assert robot_http.post(body).status_code == 200
    robot_http.heartbeat(2, events=[*events, {"id": "e-3", "type": "arrived"}])

    assert applied_events == ["e-1", "e-2", "e-3"]
    assert list(RobotEvent.objects.values_list("event_id", flat=True)) == ["e-1", "e-2", "e-3"]


def test_it_applies_an_event_repeated_within_one_heartbeat_once(robot_http, applied_events):
    robot_http.heartbeat(1, events=[{"id": "e-1", "type": "arrived"}] * 2)

    assert applied_events == ["e-1"]


def test_it_records_the_event_as_the_robot_sent_it(robot_http, robot):
    event = {"id": "e-9", "type": "arrived", "at": "2026-11-22T09:13:58Z", "note": "x"}

    robot_http.heartbeat(7, events=[event])

    stored = RobotEvent.objects.get()
    assert stored.data == event
    assert (stored.seq, stored.boot_id, stored.at.isoformat()) == (
        7,
        "boot-1",
        "2026-11-22T09:13:58+00:00",
    )


def test_it_stores_each_resource_request_once(robot_http, robot):
    request = {"id": "q-1", "type": "acquire", "resource": "ELEV", "to_floor": "2F"}

    robot_http.heartbeat(1, requests=[request])
    robot_http.heartbeat(2, requests=[request])

    stored = RobotRequest.objects.get()
    assert (stored.request_id, stored.resource, stored.to_floor) == ("q-1", "ELEV", "2F")


def test_it_ignores_the_state_of_a_stale_heartbeat_but_applies_its_events_and_acks(
    robot_http, robot, applied_events
):
    message = post_action(robot)
    robot_http.heartbeat(5, state={"status": "moving", "battery": 0.5})

    reply = robot_http.heartbeat(
        3,
        state={"status": "charging", "battery": 0.4},
        events=[{"id": "e-late", "type": "arrived"}],
        acks=[message.public_id],
    )

    robot.refresh_from_db()
    assert (robot.status, robot.battery, robot.seq) == ("moving", 0.5, 5)
    assert applied_events == ["e-late"]
    assert reply["messages"] == []


def test_it_treats_an_equal_seq_as_stale(robot_http, robot):
    robot_http.heartbeat(5, state={"status": "moving"})
    robot_http.heartbeat(5, state={"status": "error"})

    robot.refresh_from_db()
    assert robot.status == "moving"


def test_it_resets_the_sequence_on_a_new_boot_id(robot_http, robot):
    robot_http.heartbeat(900, boot_id="boot-1", state={"status": "moving"})

    robot_http.heartbeat(1, boot_id="boot-2", state={"status": "idle", "battery": 0.3})

    robot.refresh_from_db()
    assert (robot.boot_id, robot.seq, robot.status, robot.battery) == ("boot-2", 1, "idle", 0.3)


def test_it_treats_a_late_heartbeat_of_an_earlier_boot_as_stale(robot_http, robot):
    robot_http.heartbeat(900, boot_id="boot-1")
    robot_http.heartbeat(1, boot_id="boot-2", state={"status": "idle"})

    robot_http.heartbeat(901, boot_id="boot-1", state={"status": "error"})

    robot.refresh_from_db()
    assert (robot.boot_id, robot.seq, robot.status) == ("boot-2", 1, "idle")


def test_it_keeps_the_reported_position_and_errors(robot_http, robot):
    robot_http.heartbeat(
        1,
        state={
            "status": "moving",
            "floor": "3F",
            "waypoint": "3F-CORR-MID",
            "x": 40.5,
            "y": -1.25,
            "heading": 3.1,
            "load": 2,
            "plan_version": 4,
            "errors": ["bumper pressed"],
        },
    )

    robot = Robot.objects.select_related("floor", "waypoint").get(pk=robot.pk)
    assert (robot.floor.code, robot.waypoint.code, robot.x, robot.y, robot.heading) == (
        "3F",
        "3F-CORR-MID",
        40.5,
        -1.25,
        3.1,
    )
    assert (robot.load, robot.plan_version, robot.errors) == (2, 4, ["bumper pressed"])


def test_it_answers_a_heartbeat_without_optional_fields(robot_http, robot):
    body = factories.heartbeat_body(1)
    for optional in ("events", "acks", "requests", "sent_at"):
        del body[optional]
    for optional in ("waypoint", "x", "y", "heading", "errors"):
        del body["state"][optional]

    response = robot_http.post(body)

    assert response.status_code == 200, response.text
    robot.refresh_from_db()
    assert robot.waypoint is None


def test_it_sends_the_wire_form_of_messages(robot_http, robot):
    body = {"plan_version": 8, "stops": [{"task": "T-1", "stop": 0, "action": "pickup"}]}
    message = board_post(robot=robot, type="plan", body=body)

    reply = robot_http.heartbeat(1)

    assert reply["messages"] == [{"id": message.public_id, "type": "plan", **body}]
    assert json.dumps(reply)  # plain JSON all the way down
    assert BoardMessage.objects.pending().count() == 1
