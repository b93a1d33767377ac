"""Middleware of every request.

RefuseNulMiddleware refuses requests whose URL carries text the database cannot store, before
any view runs. A NUL character (`%00`) in a path or query parameter reaches lookups such as
Robot.objects.filter(code=...), and PostgreSQL refuses it with an error (a 500). No code,
page or parameter of ours contains one, so the request is refused as a whole.

CSPMiddleware is django-csp's, building the policy once instead of twice a response.
"""

from functools import cache

from csp import middleware as csp
from csp.constants import HEADER, HEADER_REPORT_ONLY
from csp.utils import build_policy
from django.conf import settings
from django.core.signals import setting_changed
from django.dispatch import receiver
from django.http import HttpResponseBadRequest, JsonResponse


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


class CSPMiddleware(csp.CSPMiddleware):
    """django-csp's middleware, sending the policy built once from the settings.

    django-csp 4.0 builds both policies (enforced and report-only) from the settings on every
    response, before it looks whether it sends them: a noticeable share of the instructions a
    robot's heartbeat costs the server (bench/heartbeat_instructions.py). A response whose
    policy nothing changed (no nonce asked for; no csp, csp_update, csp_replace or csp_exempt
    decorator on its view, and none of ours has one) gets the headers built once; any other
    goes through django-csp as before.
    """

    def process_response(self, request, response):
        if _policy_changed(request, response):
            return super().process_response(request, response)
        excluded_for = request.path_info.startswith
        for header, policy, excluded in _policies():
            if policy and header not in response and not excluded_for(excluded):
                response[header] = policy
        request.csp_nonce = csp.CheckableLazyObject(self._csp_nonce_post_response)
        return response


_CHANGES = (
    *("_csp_config", "_csp_update", "_csp_replace", "_csp_exempt"),
    *("_csp_config_ro", "_csp_update_ro", "_csp_replace_ro", "_csp_exempt_ro"),
)


def _policy_changed(request, response) -> bool:
    if getattr(request, "_csp_nonce", None) is not None:
        return True
    if settings.DEBUG and response.status_code in (404, 500):
        return True  # django-csp leaves Django's debug pages without a policy
    return any(getattr(response, change, None) is not None for change in _CHANGES)


@cache
def _policies() -> tuple[tuple[str, str, tuple[str, ...]], ...]:
    """(header, policy, URL prefixes excluded from it) of the enforced and report-only ones."""
    return tuple(
        (header, build_policy(report_only=report_only), _excluded(setting))
        for header, setting, report_only in (
            (HEADER, "CONTENT_SECURITY_POLICY", False),
            (HEADER_REPORT_ONLY, "CONTENT_SECURITY_POLICY_REPORT_ONLY", True),
        )
    )


def _excluded(setting: str) -> tuple[str, ...]:
    return tuple((getattr(settings, setting, None) or {}).get("EXCLUDE_URL_PREFIXES") or ())


@receiver(setting_changed)
def _policies_forget(*, setting, **kwargs):
    if setting.startswith("CONTENT_SECURITY_POLICY"):
        _policies.cache_clear()
