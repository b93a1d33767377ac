"""A request due now is allocated in the request itself (settings.ALLOCATE_ON_REQUEST) when no
allocation runs on its site, and its robot is woken before the commit: the shortest way from a
nurse's request to the robot (bench/latency.py). Otherwise the Celery worker allocates it."""

import threading

import pytest
import redis
from asgiref.sync import async_to_sync
from channels.testing import WebsocketCommunicator
from django.conf import settings
from django.db import connection, transaction

from boards.models import BoardMessage
from boards.push import robot_group
from hospital_delivery.asgi import application
from scheduling.models import AllocationLock
from scheduling.services.allocation import NO_ROBOT
from tests.scheduling.conftest import pending_plans, plans, request, robot_ready, status
from tests.servers import poll

AT_DOCK = {"floor": "1F", "waypoint": "1F-DOCK-1"}


def test_the_request_commits_with_its_robot_chosen_and_the_plan_posted(
    r1, site, staff, enqueued, django_capture_on_commit_callbacks
):
    with django_capture_on_commit_callbacks(execute=True):
        task = request(site, user=staff, allocate_now=True)

    assert (status(task), task.robot) == ("assigned", r1)
    assert list(task.history.values_list("old", "new", "cause")) == [
        ("", "due", "request"),
        ("due", "assigned", "allocation"),
    ]
    [plan] = pending_plans(r1)
    assert list(plan.body["tasks"]) == [task.code]
    assert enqueued == []  # nothing left for the worker


def test_without_a_robot_it_stays_due_for_the_due_sweep(
    site, enqueued, django_capture_on_commit_callbacks
):
    with django_capture_on_commit_callbacks(execute=True):
        task = request(site, allocate_now=True)

    task.refresh_from_db()
    assert (task.status, task.waiting_reason) == ("due", NO_ROBOT)
    assert enqueued == []  # the due sweep offers it again every second
    assert not BoardMessage.objects.exists()


@pytest.mark.django_db(transaction=True)
def test_while_another_allocation_runs_the_request_leaves_it_to_the_worker(r1, site, enqueued):
    AllocationLock.objects.get_or_create(site=site)
    locked, release = threading.Event(), threading.Event()

    def allocation_running():
        try:
            with transaction.atomic():
                AllocationLock.objects.select_for_update().get(site=site)
                locked.set()
                release.wait(timeout=30)
        finally:
            connection.close()

    holder = threading.Thread(target=allocation_running)
    holder.start()
    try:
        assert locked.wait(timeout=10)
        task = request(site, allocate_now=True)  # returns without waiting for the lock
    finally:
        release.set()
        holder.join(timeout=30)

    assert status(task) == "due"
    assert enqueued == [task.pk]  # sent once the request committed
    assert not BoardMessage.objects.exists()


@pytest.mark.django_db(transaction=True)
def test_a_robot_woken_before_the_commit_gets_the_plan_in_the_heartbeat_it_sends(
    robot, robot_http, site
):
    robot_http.heartbeat(1, state=AT_DOCK)  # online at its dock: free for a task
    robot_ready(robot)
    woken, heartbeat_waiting = threading.Event(), threading.Event()
    outcome = {}

    async def listen():
        socket = WebsocketCommunicator(
            application,
            f"/ws/robots/{robot.code}",
            headers=[(b"authorization", f"Bearer {robot.token}".encode())],
        )
        connected, _ = await socket.connect()
        assert connected
        outcome["wake"] = await socket.receive_json_from(timeout=20)
        woken.set()
        await socket.disconnect()

    def nurse_request():
        """The request, its commit held back until the woken robot's heartbeat waits."""
        try:
            with transaction.atomic():
                outcome["task"] = request(site, allocate_now=True)
                outcome["woken_before_commit"] = woken.wait(timeout=20)
                heartbeat_waiting.wait(timeout=20)
        finally:
            connection.close()

    listener = threading.Thread(target=async_to_sync(listen))
    listener.start()
    poll(lambda: _subscribed(robot), what="the push socket joined its group")
    requester = threading.Thread(target=nurse_request)
    requester.start()
    assert woken.wait(timeout=20)
    heartbeat = threading.Thread(
        target=lambda: outcome.update(reply=robot_http.heartbeat(2, state=AT_DOCK))
    )
    heartbeat.start()
    poll(_a_backend_waits_for_a_lock, what="the heartbeat waiting for the robot's lock")
    heartbeat_waiting.set()
    for thread in (requester, heartbeat, listener):
        thread.join(timeout=30)

    assert outcome["woken_before_commit"]
    [plan] = plans(outcome["reply"])  # the heartbeat waited for the commit, then found it
    assert outcome["wake"] == {"type": "wake", "message": plan["id"]}
    assert list(plan["tasks"]) == [outcome["task"].code]


def _subscribed(robot) -> bool:
    """Whether a push socket of the robot is listening (the layer subscribed its group)."""
    config = settings.CHANNEL_LAYERS["default"]["CONFIG"]
    client = redis.Redis.from_url(config["hosts"][0])
    try:
        channel = f"{config['prefix']}__group__{robot_group(robot.code)}"
        return client.pubsub_numsub(channel)[0][1] > 0
    finally:
        client.close()


def _a_backend_waits_for_a_lock() -> bool:
    with connection.cursor() as cursor:
        cursor.execute(
            "SELECT count(*) FROM pg_stat_activity"
            " WHERE datname = current_database() AND wait_event_type = 'Lock'"
        )
        return cursor.fetchone()[0] > 0
