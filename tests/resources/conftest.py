"""Robots that ask for resources, over real HTTP (protocol v1, "Resources")."""

import itertools

import pytest

from boards.models import BoardMessage
from resources.choices import HOLDING_LEASE_STATES
from resources.models import Lease
from robots.models import Resource
from tests import factories
from tests.conftest import RobotHttp

_ids = itertools.count(1)


def new_id(prefix="q") -> str:
    return f"{prefix}-{next(_ids)}"


def of_type(messages: list[dict], type: str) -> list[dict]:
    return [message for message in messages if message["type"] == type]


def acquire(resource: str, *, id: str | None = None, to_floor: str | None = None) -> dict:
    request = {"id": id or new_id(), "type": "acquire", "resource": resource}
    if to_floor:
        request["to_floor"] = to_floor
    return request


def release(resource: str, *, id: str | None = None) -> dict:
    return {"id": id or new_id(), "type": "release", "resource": resource}


def event(type: str, resource: str) -> dict:
    return {"id": new_id("e"), "type": type, "resource": resource}


class Bot:
    """A robot heartbeating over HTTP: numbers its heartbeats and returns the board it sees."""

    def __init__(self, http: RobotHttp):
        self.http = http
        self.robot = http.robot
        self.seq = 0

    @property
    def code(self) -> str:
        return self.robot.code

    def post(self, *, requests=(), events=(), acks=(), floor: str = "1F"):
        self.seq += 1
        body = factories.heartbeat_body(
            self.seq,
            state={"floor": floor, "waypoint": None},
            requests=list(requests),
            events=list(events),
            acks=list(acks),
        )
        return self.http.post(body)

    def beat(self, **fields) -> list[dict]:
        """One heartbeat; the messages on the robot's board."""
        response = self.post(**fields)
        assert response.status_code == 200, response.text
        return response.json()["messages"]

    def acquire(self, resource: str, **fields) -> list[dict]:
        return self.beat(requests=[acquire(resource, **fields)])

    def release(self, resource: str) -> list[dict]:
        return self.beat(requests=[release(resource)])

    def entered(self, resource: str) -> list[dict]:
        return self.beat(events=[event("resource_entered", resource)])

    def left(self, resource: str) -> list[dict]:
        return self.beat(events=[event("resource_released", resource)])


@pytest.fixture
def make_bot(live_server, site):
    def make(code: str | None = None) -> Bot:
        return Bot(RobotHttp(live_server.url, factories.robot_create(site, code)))

    return make


def lease_of(bot: Bot, resource: str) -> Lease:
    """The robot's newest lease on the resource."""
    return Lease.objects.filter(robot=bot.robot, resource__code=resource).latest("pk")


def holders(resource: str) -> list[str]:
    leases = Lease.objects.filter(resource__code=resource, state__in=HOLDING_LEASE_STATES)
    return sorted(leases.values_list("robot__code", flat=True))


def messages_about(lease: Lease, type: str) -> list[BoardMessage]:
    """Every message ever posted about a lease (acked, withdrawn or pending)."""
    return list(BoardMessage.objects.filter(robot=lease.robot, key=lease.board_key, type=type))


def resource(code: str) -> Resource:
    return Resource.objects.get(code=code)
