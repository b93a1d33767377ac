"""The scheduler with a real Celery worker process and Redis (not eager mode).

Requests reach the worker as Celery messages sent on commit; robots heartbeat over real HTTP
(the live server). Sweeps are sent as messages too, as Celery beat would send them.
"""

import os
import uuid
from datetime import timedelta

import pytest
import requests
from django.utils import timezone

from hospital_delivery.celery import app as celery_app
from robots.models import Robot
from robots.services import presence_sweep
from scheduling import tasks as celery_tasks
from scheduling.models import Task
from tests import factories, servers
from tests.conftest import RobotHttp
from tests.scheduling.conftest import event, plans, request, robot_ready

pytestmark = pytest.mark.slow


@pytest.fixture(scope="session")
def worker(django_db_setup, django_db_blocker):
    name = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with servers.celery_worker(queue=f"hd-test-worker-{name}-{uuid.uuid4().hex[:8]}") as worker:
        yield worker


@pytest.fixture
def celery(worker, transactional_db):
    """Messages of this test go to the worker; it is idle again before the database is reset."""
    previous = celery_app.conf.task_default_queue
    celery_app.conf.task_default_queue = worker.queue
    yield worker
    celery_app.conf.task_default_queue = previous
    worker.wait_idle()


class Bot(RobotHttp):
    """A robot heartbeating over HTTP that numbers its heartbeats and acks what it gets."""

    def __init__(self, base_url, robot):
        super().__init__(base_url, robot)
        self.seq = 0

    def beat(self, **fields) -> dict:
        self.seq += 1
        fields.setdefault("state", {"floor": "1F", "waypoint": self.robot.dock.code})
        return self.heartbeat(self.seq, **fields)

    def wait_for_plan(self, check=lambda plan: True) -> dict:
        def newest():
            found = [plan for plan in plans(self.beat()) if check(plan)]
            return found[-1] if found else None

        return servers.poll(newest, timeout=30, what=f"a plan for {self.robot.code}")


def holder(task: Task) -> Robot | None:
    task.refresh_from_db()
    return task.robot if task.status == "assigned" else None


@pytest.fixture
def bots(live_server, site):
    def make(code, dock="1F-DOCK-1"):
        robot = factories.robot_create(site, code, dock=site.waypoints.get(code=dock))
        return Bot(live_server.url, robot)

    return make


def test_a_request_becomes_a_plan_in_a_heartbeat_response(celery, bots, live_server, staff):
    bot = bots("R1")
    bot.beat()

    response = requests.post(
        f"{live_server.url}/api/v1/tasks/",
        json={
            "sender": "Ward 3",
            "receiver": "Lab",
            "contents": "Blood samples",
            "pickups": ["3F-WARD"],
            "dropoffs": ["2F-LAB"],
        },
        headers={"Authorization": f"Bearer {staff.api_token_plain}"},
        timeout=30,
    )
    assert response.status_code == 201, response.text
    code = response.json()["code"]

    plan = bot.wait_for_plan()
    assert list(plan["tasks"]) == [code]
    assert [(s["task"], s["action"], s["waypoint"]) for s in plan["stops"]] == [
        (code, "pickup", "3F-WARD"),
        (code, "dropoff", "2F-LAB"),
    ]
    assert plan["stops"][0]["via"] == ["1F-ELEV-WAIT", "3F-ELEV-WAIT"]


def test_an_ack_timeout_reallocates_the_task(celery, bots, site):
    first, second = bots("R1"), bots("R2", dock="1F-DOCK-2")
    for bot in (first, second):
        bot.beat()
    task = request(site)
    assert servers.poll(lambda: holder(task), what="the task assigned") == first.robot

    Task.objects.filter(pk=task.pk).update(ack_due_at=timezone.now() - timedelta(seconds=1))

    def swept_to_second():
        celery_tasks.ack_timeout_sweep.delay()  # as Celery beat sends it every second
        return holder(task) == second.robot

    servers.poll(swept_to_second, interval=0.5, what="the task given to R2")

    assert [stop["action"] for stop in first.wait_for_plan()["stops"]] == ["dock"]
    assert list(second.wait_for_plan()["tasks"]) == [task.code]
    assert task.history.filter(cause="ack_timeout").count() == 1


def test_cancelling_an_acknowledged_task_posts_a_plan_without_it(
    celery, bots, site, live_server, staff
):
    bot = bots("R1")
    bot.beat()
    task = request(site)
    plan = bot.wait_for_plan()
    bot.beat(acks=[plan["id"]])
    assert Task.objects.get(pk=task.pk).status == "acknowledged"

    response = requests.post(
        f"{live_server.url}/api/v1/tasks/{task.code}/cancel",
        headers={"Authorization": f"Bearer {staff.api_token_plain}"},
        timeout=30,
    )

    assert response.status_code == 200, response.text
    assert response.json()["status"] == "cancelled"
    replan = bot.wait_for_plan()
    assert replan["plan_version"] == plan["plan_version"] + 1
    assert [stop["action"] for stop in replan["stops"]] == ["dock"]


def test_an_offline_robots_task_goes_to_another_robot(celery, bots, site):
    first = bots("R1")
    first.beat()
    task = request(site)
    servers.poll(lambda: holder(task), what="the task assigned")
    loaded = request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",))
    servers.poll(lambda: holder(loaded), what="the second task assigned")
    first.beat(acks=[first.wait_for_plan()["id"]], events=[event("loaded", loaded.code, 0)])
    second = robot_ready(factories.robot_create(site, "R2"))
    first.robot.refresh_from_db()

    presence_sweep(now=first.robot.offline_at + timedelta(milliseconds=1))

    assert servers.poll(lambda: holder(task), what="the task reallocated") == second
    loaded.refresh_from_db()
    assert (loaded.status, loaded.robot) == ("picked_up", first.robot)


def test_a_lost_message_is_made_up_for_by_the_due_sweep(celery, bots, site, monkeypatch):
    bot = bots("R1")
    bot.beat()
    with monkeypatch.context() as lost:
        lost.setattr(celery_tasks.allocate_task, "delay", lambda task_id, **_: None)
        task = request(site)
    celery.wait_idle()
    assert holder(task) is None

    celery_tasks.due_sweep.delay()  # what Celery beat sends every second

    assert servers.poll(lambda: holder(task), what="the task assigned") == bot.robot
    assert list(bot.wait_for_plan()["tasks"]) == [task.code]
