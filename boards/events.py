"""Live pushes over Channels, always sent after the transaction that caused them commits.

Two audiences: the pages watching a site (group "site-<id>", see the UI consumers) and a
robot's optional push channel (group "robot-<code>", protocol v1 "Push channel"), which only
ever carries a wake-up: board contents travel in heartbeat responses alone.

A push is a courtesy, never the record: if Redis is down the change is still committed and
pages re-read state when they reconnect, robots still heartbeat. So failures are logged,
not raised (robust on_commit).
"""

import logging

from asgiref.sync import async_to_sync
from channels.layers import get_channel_layer
from django.db import transaction

logger = logging.getLogger(__name__)


def site_group(site_id: int) -> str:
    return f"site-{site_id}"


def robot_group(robot_code: str) -> str:
    return f"robot-{robot_code}"


def publish_on_commit(*, site_id: int, kind: str, data: dict) -> None:
    """Tell the pages watching site_id that `kind` happened (e.g. "robot", "task", "lease")."""
    message = {"type": "site.event", "kind": kind, "data": data}
    transaction.on_commit(lambda: _send(site_group(site_id), message), robust=True)


def wake_on_commit(*, robot_code: str, message_id: str) -> None:
    """Ask a robot with an open push channel to heartbeat now (it will find message_id)."""
    message = {"type": "robot.wake", "message": message_id}
    transaction.on_commit(lambda: _send(robot_group(robot_code), message), robust=True)


def _send(group: str, message: dict) -> None:
    layer = get_channel_layer()
    if layer is None:
        return
    async_to_sync(layer.group_send)(group, message)
