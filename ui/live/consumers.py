"""The pages' websocket: every live event of one site (ui/live/publish.py), forwarded as
{"kind": ..., "data": ...}. It authenticates, joins groups and forwards; no queries beyond
authentication and finding the site.
"""

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer

from core.access import is_member
from robots.membership import may_see_site
from robots.models import Site
from ui.live.publish import session_group, site_group

CLOSE_UNAUTHORIZED = 4401
CLOSE_FORBIDDEN = 4403
CLOSE_NOT_FOUND = 4404


class SiteConsumer(AsyncJsonWebsocketConsumer):
    """A page watching one site: every `site.event` of the site as {"kind": ..., "data": ...}.

    Needs a logged-in user (session cookie, AuthMiddlewareStack) in the nurse or operator group
    (or staff), and an allowed Origin (AllowedHostsOriginValidator, hospital_delivery/routing.py).
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
        """Its session logged out (ui.live.publish.on_user_logged_out): log in again."""
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
