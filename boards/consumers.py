"""Websocket consumers: the robot push channel (protocol v1, "Push channel": wake-ups only,
never board contents) and the pages' live site events.

Consumers only authenticate, join groups and forward what services published after commit
(boards.events); they never query beyond authentication.
"""

from datetime import datetime
from urllib.parse import parse_qs

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer

from boards.events import robot_group, session_group, site_group
from hospital_delivery.access import is_member
from hospital_delivery.membership import may_see_site
from hospital_delivery.tokens import bearer_token
from robots.models import Site
from robots.services import robot_authenticate

CLOSE_UNAUTHORIZED = 4401
CLOSE_FORBIDDEN = 4403
CLOSE_NOT_FOUND = 4404


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
            await self.channel_layer.group_add(self.group, self.channel_name)

    async def disconnect(self, code):
        if hasattr(self, "group"):
            await self.channel_layer.group_discard(self.group, self.channel_name)

    async def receive_json(self, content, **kwargs):
        """Robots have nothing to say here: everything they report goes in heartbeats."""

    async def robot_wake(self, event):
        await self.send_json({"type": "wake", "message": event["message"]})

    async def robot_token_revoked(self, event):
        """The robot's token was rotated (robot_token_issue): a socket of an older token closes;
        one opened with the new token in the meantime stays."""
        rotated_at = datetime.fromisoformat(event["issued_at"])
        if self.token_issued_at is None or self.token_issued_at < rotated_at:
            await self.close(code=CLOSE_UNAUTHORIZED)


class SiteConsumer(AsyncJsonWebsocketConsumer):
    """A page watching one site: every `site.event` of the site as {"kind": ..., "data": ...}.

    Needs a logged-in user (session cookie, AuthMiddlewareStack) in the nurse or operator group
    (or staff), and an allowed Origin (AllowedHostsOriginValidator, hospital_delivery.routing).
    Refusals accept first and then close, so the close code reaches the browser: 4401 not
    logged in, 4403 not allowed, 4404 no such site. The group is joined before the socket is
    accepted, so a page that re-reads the state once open misses no event in between. When its
    login session logs out, the socket closes with 4401 (other sessions of the user stay open).
    """

    async def connect(self):
        user = self.scope.get("user")
        code = self.scope["url_route"]["kwargs"]["site"]
        refusal, site_id = await database_sync_to_async(_site_access)(user, code)
        if refusal:
            await self.accept()
            await self.close(code=refusal)
            return
        self.groups = [site_group(site_id)]
        session_key = self.scope["session"].session_key
        if session_key:
            self.groups.append(session_group(session_key))
        for group in self.groups:
            await self.channel_layer.group_add(group, self.channel_name)
        await self.accept()  # the base class leaves self.groups when the socket closes

    async def session_ended(self, event):
        """Its session logged out (boards.receivers): the page must log in again."""
        await self.close(code=CLOSE_UNAUTHORIZED)

    async def receive_json(self, content, **kwargs):
        """Pages only listen: everything they do goes through HTTP."""

    async def site_event(self, event):
        await self.send_json({"kind": event["kind"], "data": event["data"]})


def _site_access(user, code: str) -> tuple[int | None, int | None]:
    """(close code, None) if refused, else (None, the site's id)."""
    if user is None or not user.is_authenticated:
        return CLOSE_UNAUTHORIZED, None
    if not is_member(user):
        return CLOSE_FORBIDDEN, None
    site_id = Site.objects.filter(code=code).values_list("pk", flat=True).first()
    if site_id is None:
        return CLOSE_NOT_FOUND, None
    if not may_see_site(user, site_id):
        return CLOSE_FORBIDDEN, None
    return None, site_id
