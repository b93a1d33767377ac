"""axe-core (npm, pinned in package.json) over every page of ours, as the person who uses it,
at desktop, tablet and phone widths: no critical or serious violation. The API docs are
Swagger UI's page, a third party's, and are left out."""

from pathlib import Path

import pytest
from django.conf import settings
from django.test import Client

from scheduling.services import task_allocate
from tests.conftest import RobotHttp
from tests.scheduling.conftest import request

pytestmark = pytest.mark.browser

AXE = Path(settings.BASE_DIR, "node_modules", "axe-core", "axe.min.js")
WIDTHS = {
    "desktop": {"width": 1366, "height": 768},
    "tablet": {"width": 768, "height": 1024},
    "phone": {"width": 390, "height": 844},
}
# The WCAG 2.1 A and AA rules; what axe calls critical or serious fails the test.
RUN_AXE = """
async () => {
  const result = await axe.run(document, {
    runOnly: ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa"],
  });
  return result.violations
    .filter((v) => v.impact === "critical" || v.impact === "serious")
    .map((v) => `${v.id} (${v.impact}): ${v.nodes.slice(0, 3).map((n) => n.target).join(" | ")}`);
}
"""


def pages_of(task_code: str) -> dict[str, list[str]]:
    """Each persona's pages (paths of the test site)."""
    return {
        "nurse": [
            "/",
            "/stations/",
            "/stations/3F-WARD/",
            "/recurring/",
            f"/deliveries/{task_code}/",
            "/fleet/",
            "/robots/R1/",
            "/account/pin/",
        ],
        "operator": ["/fleet/?floor=2F", "/reports/", "/webhooks/"],
        "staff": ["/maps/tiny/edit", "/maps/tiny/history"],
        None: ["/accounts/login/"],
    }


def session_of(user) -> list[dict]:
    if user is None:
        return []
    client = Client()
    client.force_login(user)
    return [
        {
            "name": settings.SESSION_COOKIE_NAME,
            "value": client.cookies[settings.SESSION_COOKIE_NAME].value,
        }
    ]


@pytest.mark.parametrize("width", WIDTHS)
def test_it_finds_no_serious_accessibility_violation(
    chromium, page_servers, nurse, operator, staff, robot, site, width
):
    RobotHttp(page_servers.http, robot).heartbeat(1)
    task = request(site, dropoffs=("3F-WARD",), contents="Blood sample", user=nurse)
    assert task_allocate(task_id=task.pk)
    axe = AXE.read_text(encoding="utf-8")
    people = {"nurse": nurse, "operator": operator, "staff": staff, None: None}
    found = {}
    for persona, paths in pages_of(task.code).items():
        # bypass_csp: the pages allow no inline script, and axe is injected as one.
        context = chromium.new_context(
            viewport=WIDTHS[width], base_url=page_servers.http, bypass_csp=True
        )
        for cookie in session_of(people[persona]):
            context.add_cookies([{**cookie, "url": page_servers.http}])
        page = context.new_page()
        for path in paths:
            page.goto(path)
            page.wait_for_load_state("load")
            page.add_script_tag(content=axe)
            problems = page.evaluate(RUN_AXE)
            if problems:
                found[f"{persona} {path}"] = problems
        context.close()

    assert found == {}
