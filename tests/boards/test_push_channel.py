"""Protocol v1 push channel: a robot-opened websocket that only carries wake-ups."""

import pytest
from asgiref.sync import async_to_sync
from channels.db import database_sync_to_async
from channels.testing import WebsocketCommunicator

from boards.services import board_post
from hospital_delivery.asgi import application
from tests import factories

pytestmark = pytest.mark.django_db(transaction=True)


def connect(robot_code, *, token=None, query_token=None):
    path = f"/ws/robots/{robot_code}"
    if query_token:
        path += f"?token={query_token}"
    headers = [(b"authorization", f"Bearer {token}".encode())] if token else []
    return WebsocketCommunicator(application, path, headers=headers)


def run(scenario):
    return async_to_sync(scenario)()


def test_it_wakes_a_robot_when_something_is_posted_for_it(robot):
    async def scenario():
        socket = connect(robot.code, token=robot.token)
        connected, _ = await socket.connect()
        assert connected
        message = await database_sync_to_async(board_post)(
            robot=robot, type="action", body={"action": "pause"}
        )
        wake = await socket.receive_json_from(timeout=5)
        await socket.disconnect()
        return message, wake

    message, wake = run(scenario)

    assert wake == {"type": "wake", "message": message.public_id}


def test_it_accepts_the_token_as_a_query_parameter(robot):
    async def scenario():
        socket = connect(robot.code, query_token=robot.token)
        await socket.connect()
        message = await database_sync_to_async(board_post)(
            robot=robot, type="action", body={"action": "resume"}
        )
        wake = await socket.receive_json_from(timeout=5)
        await socket.disconnect()
        return message, wake

    message, wake = run(scenario)

    assert wake["message"] == message.public_id


def test_it_never_sends_board_contents_or_other_robots_wakes(robot, site):
    other = factories.robot_create(site, "R2")

    async def scenario():
        socket = connect(robot.code, token=robot.token)
        await socket.connect()
        await database_sync_to_async(board_post)(
            robot=other, type="action", body={"action": "pause"}
        )
        mine = await database_sync_to_async(board_post)(
            robot=robot, type="action", body={"action": "pause"}
        )
        wake = await socket.receive_json_from(timeout=5)
        nothing_else = await socket.receive_nothing(timeout=0.2)
        await socket.disconnect()
        return mine, wake, nothing_else

    mine, wake, nothing_else = run(scenario)

    assert wake == {"type": "wake", "message": mine.public_id}
    assert nothing_else


@pytest.mark.parametrize(("token", "close_code"), [(None, 4401), ("wrong", 4401)])
def test_it_closes_with_4401_without_a_valid_token(robot, token, close_code):
    async def scenario():
        socket = connect(robot.code, token=token)
        await socket.connect()
        return await socket.receive_output(timeout=5)

    closed = run(scenario)

    assert closed == {"type": "websocket.close", "code": close_code}


def test_it_closes_with_4403_for_another_robots_token(robot, site):
    other = factories.robot_create(site, "R2")

    async def scenario():
        socket = connect(robot.code, token=other.token)
        await socket.connect()
        return await socket.receive_output(timeout=5)

    assert run(scenario) == {"type": "websocket.close", "code": 4403}
