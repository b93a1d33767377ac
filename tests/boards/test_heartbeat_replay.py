"""A heartbeat stream with lost requests, lost responses, duplicates and reordering ends the
server in exactly the state that the same stream without any loss does."""

import random
from dataclasses import dataclass, field

import pytest

from boards.models import BoardMessage, RobotEvent
from boards.services import board_post
from robots.models import Robot
from tests import factories
from tests.conftest import RobotHttp

STEPS = 60


@dataclass
class RobotSide:
    """What a protocol v1 robot keeps: events until answered, acks until answered."""

    http: RobotHttp
    seq: int = 0
    unsent_events: list = field(default_factory=list)
    unsent_acks: set = field(default_factory=set)
    applied_messages: dict = field(default_factory=dict)

    def next_body(self, state, new_events):
        self.seq += 1
        self.unsent_events += new_events
        return factories.heartbeat_body(
            self.seq,
            state=state,
            events=list(self.unsent_events),
            acks=sorted(self.unsent_acks),
        )

    def answered(self, body, reply):
        carried = {event["id"] for event in body["events"]}
        self.unsent_events = [e for e in self.unsent_events if e["id"] not in carried]
        self.unsent_acks -= set(body["acks"])
        for message in reply["messages"]:
            self.applied_messages.setdefault(message["id"], message)  # de-duplicate by id
            self.unsent_acks.add(message["id"])

    def send(self, body):
        response = self.http.post(body)
        assert response.status_code == 200, response.text
        return response.json()


def world(step):
    """What happens at each step, identical for both robots: state, new events, posts."""
    state = {
        "status": ["moving", "waiting_load", "moving", "waiting_unload"][step % 4],
        "battery": round(1 - step / 200, 3),
        "load": step % 3,
        "plan_version": step // 10,
        "waypoint": ["1F-HALL", "1F-PHARM", "2F-LAB", "3F-WARD"][step % 4],
        "floor": ["1F", "1F", "2F", "3F"][step % 4],
    }
    events = [{"id": f"e-{step}-{n}", "type": "arrived"} for n in range(step % 3)]
    posts = [{"action": ["pause", "resume"][step % 2]}] if step % 7 == 3 else []
    return state, events, posts


def run(robot_side, robot, network):
    delayed = []
    state = None
    for step in range(STEPS):
        state, events, posts = world(step)
        for body in posts:
            board_post(robot=robot, type="action", body=body)
        body = robot_side.next_body(state, events)
        fate = network(step)
        if fate == "delivered":
            robot_side.answered(body, robot_side.send(body))
        elif fate == "duplicated":
            robot_side.send(body)
            robot_side.answered(body, robot_side.send(body))
        elif fate == "response_lost":
            robot_side.send(body)
        elif fate == "delayed":
            delayed.append(body)
        if delayed and fate == "delivered":
            robot_side.send(delayed.pop(0))  # arrives late, after newer ones; its reply is lost
    for body in delayed:
        robot_side.send(body)
    while True:  # the network comes back: the robot heartbeats until it has nothing left
        body = robot_side.next_body(state, [])
        reply = robot_side.send(body)
        robot_side.answered(body, reply)
        if not body["events"] and not body["acks"] and not reply["messages"]:
            return


def server_state(robot):
    robot = Robot.objects.select_related("floor", "waypoint").get(pk=robot.pk)
    return {
        "state": (
            robot.status,
            robot.floor.code,
            robot.waypoint.code,
            robot.battery,
            robot.load,
            robot.plan_version,
        ),
        "events": list(
            RobotEvent.objects.filter(robot=robot).order_by("id").values_list("event_id", flat=True)
        ),
        "acked": list(
            BoardMessage.objects.filter(robot=robot, acked_at__isnull=False)
            .order_by("id")
            .values_list("body", flat=True)
        ),
        "pending": BoardMessage.objects.pending().filter(robot=robot).count(),
    }


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_lossy_stream_ends_in_the_state_of_the_loss_free_stream(live_server, site, seed):
    rng = random.Random(seed)
    clean_robot, lossy_robot = (
        factories.robot_create(site, "CLEAN"),
        factories.robot_create(site, "LOSSY"),
    )
    fates = ["delivered"] * 5 + ["lost", "response_lost", "duplicated", "delayed"] * 1

    run(RobotSide(RobotHttp(live_server.url, clean_robot)), clean_robot, lambda step: "delivered")
    lossy_side = RobotSide(RobotHttp(live_server.url, lossy_robot))
    run(lossy_side, lossy_robot, lambda step: rng.choice(fates))

    clean, lossy = server_state(clean_robot), server_state(lossy_robot)
    assert lossy == clean
    assert len(clean["events"]) == sum(step % 3 for step in range(STEPS))
    assert clean["pending"] == 0
    assert len(lossy_side.applied_messages) == len(clean["acked"])
