"""The robots' push channel (protocol v1, "Push channel"): a robot-opened websocket that only
ever carries wake-ups (boards/push.py), never board contents. The consumer authenticates the
robot, joins its group and forwards; it never queries beyond authentication.

A robot keeps at most settings.PUSH_SOCKETS_PER_ROBOT sockets open, the newest: each socket,
once open, tells the robot's group; a socket that has heard of that many newer ones closes
with 4409, so a leaked or stolen token cannot hold sockets without end, and a robot that
reconnects without closing its old socket loses nothing.
"""

from datetime import datetime
from urllib.parse import parse_qs

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer
from django.conf import settings

from boards.push import robot_group
from core.tokens import bearer_token
from robots.services import robot_authenticate

CLOSE_UNAUTHORIZED = 4401
CLOSE_FORBIDDEN = 4403
CLOSE_REPLACED = 4409


def token_of(scope) -> str | None:
    """From `Authorization: Bearer <token>`, or `?token=` for clients that cannot set headers."""
    headers = dict(scope.get("headers", []))
    token = bearer_token(headers.get(b"authorization", b"").decode("latin-1"))
    if token is None:
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        token = (query.get("token") or [None])[0]
    return token


class RobotPushConsumer(AsyncJsonWebsocketConsumer):
    async def connect(self):
        code = self.scope["url_route"]["kwargs"]["robot"]
        token = token_of(self.scope)
        robot = await database_sync_to_async(robot_authenticate)(token=token) if token else None
        # Accept first: a close code only reaches the client on an accepted socket.
        await self.accept()
        if robot is None:
            await self.close(code=CLOSE_UNAUTHORIZED)
        elif robot.code != code:
            await self.close(code=CLOSE_FORBIDDEN)
        else:
            self.token_issued_at = robot.token_issued_at
            self.group = robot_group(code)
            self.newer_sockets = 0
            await self.channel_layer.group_add(self.group, self.channel_name)
            opened = {"type": "robot.socket_opened", "channel": self.channel_name}
            await self.channel_layer.group_send(self.group, opened)

    async def disconnect(self, code):
        if hasattr(self, "group"):
            await self.channel_layer.group_discard(self.group, self.channel_name)

    async def receive_json(self, content, **kwargs):
        """Robots have nothing to say here: everything they report goes in heartbeats."""

    async def robot_wake(self, event):
        await self.send_json({"type": "wake", "message": event["message"]})

    async def robot_socket_opened(self, event):
        """Another socket of this robot opened: this one closes once it is not among the
        newest PUSH_SOCKETS_PER_ROBOT."""
        if event["channel"] == self.channel_name:
            return
        self.newer_sockets += 1
        if self.newer_sockets >= settings.PUSH_SOCKETS_PER_ROBOT:
            await self.close(code=CLOSE_REPLACED)

    async def robot_token_revoked(self, event):
        """The robot's token was rotated (robot_token_issue): a socket of an older token closes;
        one opened with the new token in the meantime stays."""
        rotated_at = datetime.fromisoformat(event["issued_at"])
        if self.token_issued_at is None or self.token_issued_at < rotated_at:
            await self.close(code=CLOSE_UNAUTHORIZED)
