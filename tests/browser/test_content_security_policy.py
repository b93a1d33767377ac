"""Every page works under the Content-Security-Policy: no violation, and its scripts run."""

import pytest
from django.conf import settings
from django.test import Client
from playwright.sync_api import expect

pytestmark = pytest.mark.browser

# Runs before the page's own scripts (Playwright injects it, the policy does not apply to it).
RECORD_VIOLATIONS = """
window.cspViolations = [];
document.addEventListener("securitypolicyviolation",
    (e) => window.cspViolations.push(`${e.violatedDirective} ${e.blockedURI}`));
"""


@pytest.fixture
def browse(chromium, page_servers, site):
    def open_(user, path: str):
        context = chromium.new_context(base_url=page_servers.http)
        context.add_init_script(RECORD_VIOLATIONS)
        if user is not None:
            client = Client()
            client.force_login(user)
            session = client.cookies[settings.SESSION_COOKIE_NAME].value
            cookie = {"name": settings.SESSION_COOKIE_NAME, "value": session}
            context.add_cookies([{**cookie, "url": page_servers.http}])
        page = context.new_page()
        response = page.goto(path)
        assert "default-src 'self'" in response.headers["content-security-policy"]
        return page

    return open_


def violations(page) -> list[str]:
    return page.evaluate("window.cspViolations")


@pytest.mark.parametrize("path", ["/", "/fleet/", "/robots/R1/"])
def test_the_live_pages_run_under_the_policy(browse, staff, robot, path):
    page = browse(staff, path)

    expect(page.locator("#live-status")).to_have_text("Live")  # live.js connected
    assert violations(page) == []


def test_the_login_page_runs_under_the_policy(browse):
    page = browse(None, "/accounts/login/")

    expect(page.get_by_role("button", name="Log in")).to_be_visible()
    assert violations(page) == []


def test_the_api_docs_render_under_the_policy(browse, staff):
    page = browse(staff, "/api/docs/")

    expect(page.locator(".swagger-ui .opblock").first).to_be_visible()
    expect(page.get_by_text("/api/v1/tasks/").first).to_be_visible()
    assert violations(page) == []


def test_the_admin_runs_under_the_policy(browse, staff, robot):
    staff.is_superuser = True
    staff.save(update_fields=["is_superuser"])

    page = browse(staff, "/admin/robots/robot/")

    expect(page.locator("#result_list")).to_be_visible()
    assert violations(page) == []
