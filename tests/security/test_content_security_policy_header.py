"""The Content-Security-Policy header, built once from the settings (core.middleware)."""

import pytest
from csp.constants import NONCE, SELF
from csp.decorators import csp_exempt, csp_update
from csp.middleware import CSPMiddleware as LibraryMiddleware
from django.http import HttpResponse
from django.test import RequestFactory, override_settings

from core.middleware import CSPMiddleware

REPORT_ONLY = {"DIRECTIVES": {"default-src": ["'none'"], "report-uri": "/csp-reports"}}


def headers_of(middleware_class, view, path="/requests/"):
    request = RequestFactory().get(path)
    middleware = middleware_class(lambda request: view(request))
    response = middleware(request)
    return {name: value for name, value in response.headers.items() if "Content-Security" in name}


def plain(request):
    return HttpResponse("page")


def test_a_page_gets_the_same_policy_as_from_django_csp():
    ours = headers_of(CSPMiddleware, plain)

    assert ours == headers_of(LibraryMiddleware, plain)
    assert "frame-ancestors 'none'" in ours["Content-Security-Policy"]


@pytest.mark.parametrize("path", ["/requests/", "/reports/"])
def test_a_policy_changed_in_the_settings_is_the_one_sent(path):
    with override_settings(
        CONTENT_SECURITY_POLICY_REPORT_ONLY={**REPORT_ONLY, "EXCLUDE_URL_PREFIXES": ["/reports/"]}
    ):
        ours = headers_of(CSPMiddleware, plain, path)
        library = headers_of(LibraryMiddleware, plain, path)
    after = headers_of(CSPMiddleware, plain, path)

    assert ours == library
    assert ("Content-Security-Policy-Report-Only" in ours) == (path == "/requests/")
    assert "Content-Security-Policy-Report-Only" not in after


def test_a_view_that_changes_its_policy_keeps_its_change():
    updated = csp_update({"img-src": ["https://images.example"]})(plain)
    exempt = csp_exempt()(plain)

    assert "https://images.example" in headers_of(CSPMiddleware, updated)["Content-Security-Policy"]
    assert headers_of(CSPMiddleware, exempt) == {}


def test_a_page_that_asked_for_a_nonce_has_it_in_its_policy():
    def with_nonce(request):
        return HttpResponse(f"<script nonce='{request.csp_nonce}'></script>")

    with override_settings(CONTENT_SECURITY_POLICY={"DIRECTIVES": {"script-src": [SELF, NONCE]}}):
        request = RequestFactory().get("/requests/")
        response = CSPMiddleware(with_nonce)(request)

    assert f"'nonce-{request._csp_nonce}'" in response.headers["Content-Security-Policy"]
