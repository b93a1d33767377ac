"""Delivery tasks: robots that heartbeat, requests, and a place for Celery messages to go."""

import itertools
import os
import uuid
from datetime import timedelta

import pytest
from django.test import Client, override_settings
from django.utils import timezone

from boards.models import BoardMessage
from hospital_delivery.celery import app as celery_app
from robots.models import Robot, Waypoint
from scheduling import tasks as celery_tasks
from scheduling.models import Task
from scheduling.services import history, task_request
from tests import factories, servers

_event_ids = itertools.count(1)


@pytest.fixture(scope="session", autouse=True)
def celery_sink_queue():
    """Messages enqueued by tests go to a queue of this test session's own, which no worker
    reads unless a test starts one on it (tests/scheduling/test_celery.py)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    queue = f"hd-test-sink-{worker}-{uuid.uuid4().hex[:8]}"
    previous = celery_app.conf.task_default_queue
    celery_app.conf.task_default_queue = queue
    yield queue
    celery_app.conf.task_default_queue = previous
    servers.celery_queue_delete(celery_app, queue)


@pytest.fixture
def enqueued(monkeypatch):
    """Task ids handed to Celery for allocation (the message itself is not sent), each: no
    worker takes these messages, so none may hold the next back (scheduling/pending.py)."""
    sent = []
    monkeypatch.setattr(
        celery_tasks.allocate_task, "delay", lambda task_id, **_: sent.append(task_id)
    )
    monkeypatch.setattr(history, "allocation_pending_claim", lambda site_id, queue: "claimed")
    return sent


def new_event_id() -> str:
    return f"e-{next(_event_ids)}-{uuid.uuid4().hex[:6]}"


def event(type: str, task: str | None = None, stop: int | None = None, **extra) -> dict:
    body = {"id": new_event_id(), "type": type, **extra}
    if task is not None:
        body["task"] = task
    if stop is not None:
        body["stop"] = stop
    return body


def robot_ready(robot: Robot, *, at: str | None = None, battery=0.9, status="idle", **fields):
    """Make a robot a candidate for allocation as if it had heartbeated: online, at `at`."""
    code = at or robot.dock.code
    waypoint = Waypoint.objects.get(site=robot.site_id, code=code)
    now = timezone.now()
    Robot.objects.filter(pk=robot.pk).update(
        presence="online",
        last_seen_at=now,
        unreachable_at=now + timedelta(hours=1),
        offline_at=now + timedelta(hours=2),
        battery=battery,
        status=status,
        waypoint=waypoint,
        floor=waypoint.floor,
        **fields,
    )
    robot.refresh_from_db()
    return robot


def request(
    site,
    pickups=("1F-PHARM",),
    dropoffs=("2F-LAB",),
    *,
    user=None,
    allocate_now=False,
    **fields,
) -> Task:
    """A delivery request through the service, as the API makes it. It is left due for the
    worker's allocation (task_allocate), which tests drive, unless `allocate_now`
    (settings.ALLOCATE_ON_REQUEST, on in production)."""
    stations = {wp.code: wp for wp in Waypoint.objects.filter(site=site)}
    fields.setdefault("sender", "Pharmacy")
    fields.setdefault("receiver", "Nurse Kim")
    fields.setdefault("contents", "Medication")
    with override_settings(ALLOCATE_ON_REQUEST=allocate_now):
        return task_request(
            site=site,
            requester=user,
            pickups=[stations[code] for code in pickups],
            dropoffs=[stations[code] for code in dropoffs],
            **fields,
        )


def plans(reply: dict) -> list[dict]:
    return [message for message in reply["messages"] if message["type"] == "plan"]


def pending_plans(robot) -> list[BoardMessage]:
    return list(BoardMessage.objects.pending().filter(robot=robot, type="plan").order_by("id"))


def route(plan: dict) -> list[tuple]:
    """(task, stop, action, waypoint) of each stop of a plan, in order."""
    return [(s.get("task"), s.get("stop"), s["action"], s["waypoint"]) for s in plan["stops"]]


def status(task: Task) -> str:
    task.refresh_from_db()
    return task.status


class Beater:
    """A robot heartbeating in-process (django.test.Client): numbers its heartbeats."""

    def __init__(self, robot: Robot, client=None):
        self.robot = robot
        self.client = client or Client()
        self.seq = 0

    def post(self, *, events=(), acks=(), requests=(), **state):
        self.seq += 1
        state.setdefault("waypoint", self.robot.dock.code)
        # The tiny site's waypoint codes start with their floor's ("3F-WARD" is on 3F).
        state.setdefault("floor", (state["waypoint"] or "1F").split("-")[0])
        body = factories.heartbeat_body(
            self.seq, state=state, events=list(events), acks=acks, requests=list(requests)
        )
        return self.client.post(
            f"/api/v1/robots/{self.robot.code}/heartbeat",
            body,
            content_type="application/json",
            HTTP_AUTHORIZATION=f"Bearer {self.robot.token}",
        )

    def beat(self, **fields) -> dict:
        response = self.post(**fields)
        assert response.status_code == 200, response.content
        return response.json()

    def ack_all(self, reply: dict, **fields) -> dict:
        return self.beat(acks=[m["id"] for m in reply["messages"]], **fields)


@pytest.fixture
def r1(site):
    return robot_ready(factories.robot_create(site, "R1"))


@pytest.fixture
def r2(site):
    dock = Waypoint.objects.get(site=site, code="1F-DOCK-2")
    return robot_ready(factories.robot_create(site, "R2", dock=dock))
