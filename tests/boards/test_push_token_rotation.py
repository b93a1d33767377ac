"""Rotating a robot's token (manage.py robot_token) closes its push sockets of the old token,
and a robot keeps only its newest few sockets, over real websockets to daphne."""

import asyncio
import json
import subprocess
import sys

import pytest
from asgiref.sync import async_to_sync
from channels.db import database_sync_to_async
from django.conf import settings as django_settings
from django.core.management import call_command
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from boards.services import board_post
from robots.services import robot_token_issue
from tests import servers

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture(scope="module")
def daphne_url(django_db_setup, django_db_blocker):
    with servers.daphne() as server:
        yield server.url


async def push_socket(url: str, robot, token: str):
    """A robot's push socket, returned once it receives wake-ups (it has joined its group)."""
    socket = await connect(
        f"{url}/ws/robots/{robot.code}", additional_headers={"Authorization": f"Bearer {token}"}
    )
    posted = []
    for _ in range(100):
        message = await database_sync_to_async(board_post)(
            robot=robot, type="action", body={"action": "pause"}
        )
        posted.append(message.public_id)
        try:
            async with asyncio.timeout(0.1):
                wake = json.loads(await socket.recv())
        except TimeoutError:
            continue
        # A wake-up later than 0.1 s answers an earlier post (seen once, in CI on 2026-11-24).
        assert wake["type"] == "wake"
        assert wake["message"] in posted
        return socket
    raise AssertionError("the push socket never received a wake-up")


async def close_code(socket) -> int:
    """Reads (wake-ups still in flight) until the server closes the socket; its close code."""
    async with asyncio.timeout(10):
        try:
            while True:
                await socket.recv()
        except ConnectionClosed as closed:
            return closed.rcvd.code


def test_rotating_the_token_closes_the_old_tokens_socket(daphne_url, robot):
    async def scenario():
        old = await push_socket(daphne_url, robot, robot.token)
        await database_sync_to_async(call_command)("robot_token", robot.code)
        return await close_code(old)

    assert async_to_sync(scenario)() == 4401


def test_a_socket_of_the_new_token_keeps_receiving_wake_ups(daphne_url, robot):
    async def scenario():
        old = await push_socket(daphne_url, robot, robot.token)
        token = await database_sync_to_async(robot_token_issue)(robot=robot)
        assert await close_code(old) == 4401
        new = await push_socket(daphne_url, robot, token)  # asserts it gets wake-ups
        await new.close()

    async_to_sync(scenario)()


def test_the_command_closes_the_old_socket_though_its_process_exits_at_once(daphne_url, robot):
    # `manage.py robot_token` in a process of its own, as an administrator runs it: the close
    # is queued for its outbox thread, which must send it before the process ends.
    command = [sys.executable, "manage.py", "robot_token", robot.code]

    async def scenario():
        old = await push_socket(daphne_url, robot, robot.token)
        done = await asyncio.to_thread(
            subprocess.run,
            command,
            cwd=servers.REPO,
            env=servers.server_env(),
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert done.returncode == 0, done.stderr
        return await close_code(old)

    assert async_to_sync(scenario)() == 4401


def test_a_robot_keeps_only_its_newest_push_sockets(daphne_url, robot):
    limit = django_settings.PUSH_SOCKETS_PER_ROBOT  # as daphne reads it

    async def scenario():
        sockets = [await push_socket(daphne_url, robot, robot.token) for _ in range(limit + 2)]
        oldest = [await close_code(each) for each in sockets[:2]]
        newest = sockets[2:]
        message = await database_sync_to_async(board_post)(
            robot=robot, type="action", body={"action": "pause"}
        )
        woken = []
        for each in newest:
            async with asyncio.timeout(10):
                while (wake := json.loads(await each.recv()))["message"] != message.public_id:
                    pass
            woken.append(wake["type"])
            await each.close()
        return oldest, woken

    oldest, woken = async_to_sync(scenario)()

    assert oldest == [4409, 4409]
    assert woken == ["wake"] * limit
