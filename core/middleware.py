"""Middleware of every request.

RefuseNulMiddleware refuses requests whose URL carries text the database cannot store, before
any view runs. A NUL character (`%00`) in a path or query parameter reaches lookups such as
Robot.objects.filter(code=...), and PostgreSQL refuses it with an error (a 500). No code,
page or parameter of ours contains one, so the request is refused as a whole.

BusyMiddleware times each request, for how busy the process is (core/busy.py).
"""

from django.http import HttpResponseBadRequest, JsonResponse

from core.busy import busy


def _has_nul(request) -> bool:
    if "\x00" in request.path:
        return True
    return any("\x00" in "".join([key, *values]) for key, values in request.GET.lists())


class RefuseNulMiddleware:
    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        if not _has_nul(request):
            return self.get_response(request)
        why = ["contains a NUL character"]
        if request.path.startswith("/api/"):
            return JsonResponse({"error": "invalid", "detail": {"url": why}}, status=400)
        return HttpResponseBadRequest("The address contains a NUL character.")


class BusyMiddleware:
    """Times every request this process serves (core.busy), first in MIDDLEWARE so the other
    middleware's work counts too: the heartbeat cadence (robots/cadence.py) reads how busy the
    web workers are."""

    def __init__(self, get_response):
        self.get_response = get_response

    def __call__(self, request):
        busy.started()
        try:
            return self.get_response(request)
        finally:
            busy.finished()
