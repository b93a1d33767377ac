"""Pages' sessions end after SESSION_IDLE_MINUTES without use.

Django's session expires SESSION_COOKIE_AGE (the idle time) after it was last saved; a request
of the person using the page saves it again, so it lives on while they use it. At most once a
RENEW_SECONDS, so that browsing costs no write per request: the idle time is kept to within
that. The live pages re-read their state on their own (live.js, /live/<site>/state.json)
whenever something happens on the site: those requests do not renew it, or a page left open on
a busy ward would stay signed in for ever. An expired session is gone from the store: the next
request goes to the login page, and the page's websocket closes at its next access check
(ui/live/consumers.py).
"""

import time

RENEW_SECONDS = 60
RENEWED_KEY = "_renewed_at"  # when the session was last saved for its person's use (Unix time)
BACKGROUND_URL_NAMES = ("live-state",)


class SessionIdleMiddleware:
    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        response = self.get_response(request)
        if _used_by_a_person(request):
            now = time.time()
            if now - request.session.get(RENEWED_KEY, 0) >= RENEW_SECONDS:
                request.session[RENEWED_KEY] = now  # saved: SESSION_COOKIE_AGE from now
        return response


def on_logged_in(sender, request, user, **kwargs) -> None:
    """django.contrib.auth's user_logged_in: the new session counts as just renewed."""
    request.session[RENEWED_KEY] = time.time()


def _used_by_a_person(request) -> bool:
    """A signed-in page's request. Requests of the API signed by a token (DRF sets their user
    too) come with no session, and must not be given one."""
    user = getattr(request, "user", None)
    if user is None or not user.is_authenticated or request.session.session_key is None:
        return False
    match = request.resolver_match
    return match is None or match.url_name not in BACKGROUND_URL_NAMES
