"""Pages' sessions end after SESSION_IDLE_MINUTES without use.

Django's session expires SESSION_COOKIE_AGE (the idle time) after it was last saved; a request
of the person using the page saves it (`modified`), so it lives on while they use it. The live
pages re-read their state on their own (live.js, /live/<site>/state.json) whenever something
happens on the site: those requests do not save it, or a page left open on a busy ward would
stay signed in for ever. An expired session is gone from the store: the next request goes to
the login page, and the page's websocket closes at its next access check
(ui/live/consumers.py).
"""

BACKGROUND_URL_NAMES = ("live-state",)


class SessionIdleMiddleware:
    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        response = self.get_response(request)
        if _used_by_a_person(request):
            request.session.modified = True  # saved: SESSION_COOKIE_AGE from now
        return response


def _used_by_a_person(request) -> bool:
    user = getattr(request, "user", None)
    if user is None or not user.is_authenticated:
        return False
    match = request.resolver_match
    return match is None or match.url_name not in BACKGROUND_URL_NAMES
