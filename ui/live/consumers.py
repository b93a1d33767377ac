"""The pages' websocket: every live event of one site (ui/live/publish.py), forwarded as
{"kind": ..., "data": ...} in the page's language. It authenticates, joins groups and forwards;
it queries only to authenticate, to find the site and the page's language, and to check again
that its user still may watch it.
"""

import asyncio
from importlib import import_module

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer
from django.conf import settings
from django.contrib.auth import HASH_SESSION_KEY, SESSION_KEY, get_user_model
from django.utils.crypto import constant_time_compare

from accounts.languages import language_of_page
from core.access import is_member
from robots.membership import may_see_site
from robots.models import Site
from ui.live.publish import session_group, site_group, user_group

CLOSE_UNAUTHORIZED = 4401
CLOSE_FORBIDDEN = 4403
CLOSE_NOT_FOUND = 4404


class SiteConsumer(AsyncJsonWebsocketConsumer):
    """A page watching one site: every `site.event` of the site as {"kind": ..., "data": ...}.

    Needs a logged-in user (session cookie, AuthMiddlewareStack) in the nurse or operator group
    (or staff), and an allowed Origin (AllowedHostsOriginValidator, hospital_delivery/routing.py).
    Refusals accept first and then close, so the close code reaches the browser: 4401 not
    logged in, 4403 not allowed, 4404 no such site. The group is joined before the socket is
    accepted, so a page that re-reads the state once open misses no event in between.

    Access is checked again for as long as the socket is open: when its session logs out, or
    its user is changed (deactivated, out of a group, off the site: a message to the user's
    group, from whichever process made the change), and every LIVE_ACCESS_RECHECK_SECONDS, which
    also finds a session that has expired (SESSION_IDLE_MINUTES) and changes no message told of.
    The socket then closes: 4401 to log in again, 4403 if the user may no longer watch the site.
    """

    async def connect(self):
        user = self.scope.get("user")
        code = self.scope["url_route"]["kwargs"]["site"]
        refusal, site_id = await database_sync_to_async(_site_access)(user, code)
        if refusal:
            await self.accept()
            await self.close(code=refusal)
            return
        self.site_id, self.user_id = site_id, user.pk
        self.language = await database_sync_to_async(_page_language)(self.scope)
        self.session_key = self.scope["session"].session_key
        self.groups = [site_group(site_id), user_group(user.pk)]
        if self.session_key:
            self.groups.append(session_group(self.session_key))
        for group in self.groups:
            await self.channel_layer.group_add(group, self.channel_name)
        await self.accept()  # the base class leaves self.groups when the socket closes
        self.rechecks = asyncio.create_task(self._recheck_every())

    async def disconnect(self, code):
        rechecks = getattr(self, "rechecks", None)
        if rechecks is not None:
            rechecks.cancel()

    async def session_ended(self, event):
        """Its session logged out (ui.live.publish.on_user_logged_out): log in again."""
        await self.close(code=CLOSE_UNAUTHORIZED)

    async def access_changed(self, event):
        """Its user was changed (ui.live.publish.on_access_changed): may they still watch?"""
        await self._recheck()

    async def receive_json(self, content, **kwargs):
        """Pages only listen: everything they do goes through HTTP."""

    async def site_event(self, event):
        """The event's data, with the labels of this page's language laid over it."""
        data = event["data"]
        mine = event.get("translated", {}).get(self.language)
        await self.send_json({"kind": event["kind"], "data": {**data, **mine} if mine else data})

    async def _recheck_every(self):
        while True:
            await asyncio.sleep(settings.LIVE_ACCESS_RECHECK_SECONDS)
            await self._recheck()

    async def _recheck(self):
        refusal = await database_sync_to_async(access_withdrawn)(
            session_key=self.session_key, user_id=self.user_id, site_id=self.site_id
        )
        if refusal:
            await self.close(code=refusal)


def _page_language(scope) -> str:
    headers = dict(scope.get("headers", []))
    return language_of_page(
        session=scope.get("session"),
        cookies=scope.get("cookies", {}),
        accept_language=headers.get(b"accept-language", b"").decode("latin-1"),
    )


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


def access_withdrawn(*, session_key: str | None, user_id: int, site_id: int) -> int | None:
    """The close code if the socket's session or user may no longer watch the site, else None:
    the session read afresh (gone, expired, or its password changed: 4401), the user too
    (deactivated or deleted: 4401; out of the groups or off the site: 4403)."""
    user = get_user_model().objects.filter(pk=user_id, is_active=True).first()
    if user is None or not _session_valid(session_key, user):
        return CLOSE_UNAUTHORIZED
    if not is_member(user) or not may_see_site(user, site_id):
        return CLOSE_FORBIDDEN
    return None


def _session_valid(session_key: str | None, user) -> bool:
    if not session_key:
        return False
    data = import_module(settings.SESSION_ENGINE).SessionStore(session_key).load()
    if data.get(SESSION_KEY) != str(user.pk):
        return False
    return constant_time_compare(data.get(HASH_SESSION_KEY, ""), user.get_session_auth_hash())
