"""A 2.0 vehicle may publish its state only every 30 s while nothing happens: the bridge beats
for it with its last state while it is connected, asks it for its state once that is overdue,
and lets its presence run out only past twice its interval. Driven by Bridge.tick with the
times given, one step at a time (no broker needed: what it publishes is recorded)."""

import pytest
from django.utils import timezone

from robots.models import Robot
from tests.vda5050.conftest import vda_robot_create
from tests.vda5050.test_link import state
from vda5050.bridge import Bridge

pytestmark = pytest.mark.django_db(transaction=True)

IDENTITY = ("Acme", "SN-1")


class Recording(Bridge):
    def __init__(self):
        super().__init__(host="127.0.0.1", port=1883, interface="unused")
        self.published = []
        self.now = 1000.0  # seconds on the bridge's clock
        self.clock = lambda: self.now

    def tick_at(self, now: float) -> None:
        self.now = now
        self.tick()

    def publish(self, identity, outgoing):
        self.published.append(outgoing)
        super().publish(identity, outgoing)  # not connected: paho drops it


@pytest.fixture
def quiet(site):
    robot = vda_robot_create(site, "V1", "SN-1")
    robot.vda5050 = {"state_interval": 30}
    robot.save(update_fields=["vda5050"])
    return connected(robot)


def connected(robot):
    bridge = Recording()
    link = bridge._link(IDENTITY)
    bridge._connection(link, IDENTITY, {"connectionState": "ONLINE"})
    bridge._state(link, IDENTITY, state())  # its state came at t = 1000 s
    return bridge, robot


def seq(robot) -> int:
    return Robot.objects.get(pk=robot.pk).seq


def asked(bridge) -> int:
    return sum(
        1
        for out in bridge.published
        if out.topic == "instantActions"
        and [a["actionType"] for a in out.body["actions"]] == ["stateRequest"]
    )


def test_it_beats_for_a_connected_vehicle_between_its_states(quiet):
    bridge, robot = quiet
    before = seq(robot)
    bridge.tick_at(1000.0 + 1.0)
    bridge.tick_at(1000.0 + 2.0)
    assert seq(robot) == before + 2
    assert asked(bridge) == 0  # within its interval: nothing to ask
    assert Robot.objects.get(pk=robot.pk).presence_at(timezone.now()) == "online"


def test_it_asks_for_the_state_once_it_is_overdue(quiet):
    bridge, robot = quiet
    bridge.tick_at(1000.0 + 31.0)
    assert asked(bridge) == 1
    bridge.tick_at(1000.0 + 31.5)  # not again within a beat
    assert asked(bridge) == 1


def test_it_stops_beating_past_twice_its_interval(quiet):
    bridge, robot = quiet
    before = seq(robot)
    bridge.tick_at(1000.0 + 61.0)
    assert seq(robot) == before


def test_it_stops_beating_when_the_connection_is_broken(quiet):
    bridge, robot = quiet
    link = bridge.links[IDENTITY]
    bridge._connection(link, IDENTITY, {"connectionState": "CONNECTIONBROKEN"})
    before = seq(robot)
    bridge.tick_at(1000.0 + 2.0)
    assert seq(robot) == before


def test_it_follows_the_interval_it_observes_when_none_is_declared(site):
    robot = vda_robot_create(site, "V1", "SN-1")
    bridge, robot = connected(robot)
    bridge.now = 1045.0
    bridge._state(bridge.links[IDENTITY], IDENTITY, state(headerId=1))  # 45 s after the first
    before = seq(robot)
    bridge.tick_at(1045.0 + 85.0)  # past twice 2.0's 30 s, within twice the 45 s it takes
    assert seq(robot) == before + 1
    bridge.tick_at(1045.0 + 91.0)
    assert seq(robot) == before + 1
