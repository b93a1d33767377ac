"""The robots' push channel (protocol v1, "Push channel"): a wake-up telling a robot with an
open socket (boards/consumers.py) to heartbeat now. Board contents never travel here: only in
heartbeat responses, so a lost wake-up costs at most one heartbeat interval.
"""

from django.db import transaction

from core.outbox import send_soon
from core.pubsub import group_send


def robot_group(robot_code: str) -> str:
    return f"robot-{robot_code}"


def wake_on_commit(*, robot_code: str, message_id: str) -> None:
    """Ask a robot with an open push channel to heartbeat now (it will find message_id)."""
    transaction.on_commit(lambda: _wake(robot_code, message_id))


def wake_now(*, robot_code: str, message_id: str) -> None:
    """wake_on_commit, but at once: only for a caller holding the robot's row lock
    (robots.services.robot_lock). The heartbeat the wake causes waits for that lock, so it finds
    message_id committed, and the robot's trip to the server overlaps the rest of the
    transaction. If that rolls back, the robot has heartbeated once for nothing. Like every push,
    it leaves this thread (core/outbox.py): the caller holds a row lock and must not wait."""
    _wake(robot_code, message_id)


def robot_sockets_close(*, robot) -> None:
    """Close, after commit, the robot's push sockets opened with a token older than its current
    one (a receiver of robots.hooks.token_issued); boards/consumers.py decides by the time."""
    message = {"type": "robot.token_revoked", "issued_at": robot.token_issued_at.isoformat()}
    group = robot_group(robot.code)
    what = f"closing {robot.code}'s old sockets"
    transaction.on_commit(lambda: send_soon(lambda: group_send(group, message), what=what))


def _wake(robot_code: str, message_id: str) -> None:
    message = {"type": "robot.wake", "message": message_id}
    group = robot_group(robot_code)
    send_soon(lambda: group_send(group, message), what=f"waking {robot_code}")
