"""The nurse's pages on a phone (390 × 844): nothing scrolls sideways, and a delivery's robot,
status and arrival are on screen (tables become one card per row at ≤ 600 px). The operator's
fleet page fits too, its top bar's links wrapped, none hidden."""

import pytest
from playwright.sync_api import expect

from scheduling.services import task_allocate
from tests.conftest import RobotHttp
from tests.scheduling.conftest import request

pytestmark = pytest.mark.browser

PHONE = {"width": 390, "height": 844}
WIDER_THAN_THE_SCREEN = "document.documentElement.scrollWidth > window.innerWidth"


def on_screen(page, locator):
    expect(locator).to_be_visible()
    box = locator.bounding_box()
    assert box["x"] >= 0
    assert box["x"] + box["width"] <= PHONE["width"], locator


def test_it_shows_a_delivery_s_status_on_a_phone_without_sideways_scrolling(
    open_page, page_servers, nurse, operator, robot, site
):
    RobotHttp(page_servers.http, robot).heartbeat(1)
    task = request(site, dropoffs=("3F-WARD",), contents="Blood sample")
    assert task_allocate(task_id=task.pk)

    page = open_page(nurse, f"/?site={site.code}", viewport=PHONE)
    row = page.locator(f'#schedule tr[data-task="{task.code}"]')
    for cell in ("Robot", "Status", "Arrival"):
        on_screen(page, row.locator(f'[data-label="{cell}"]'))
    expect(row.locator('[data-label="Robot"]')).to_contain_text("R1")
    assert not page.evaluate(WIDER_THAN_THE_SCREEN)

    for path in (
        f"/stations/3F-WARD/?site={site.code}",
        f"/deliveries/{task.code}/",
        f"/stations/?site={site.code}",
        f"/recurring/?site={site.code}",
    ):
        page.goto(path)
        assert not page.evaluate(WIDER_THAN_THE_SCREEN), path
    page.goto(f"/stations/3F-WARD/?site={site.code}")
    on_screen(page, page.locator(f'#incoming tr[data-task="{task.code}"] [data-label="Status"]'))

    fleet = open_page(operator, f"/fleet/?site={site.code}", viewport=PHONE)
    assert not fleet.evaluate(WIDER_THAN_THE_SCREEN)
    for link in ("Reports", "Webhooks"):
        on_screen(
            fleet, fleet.get_by_role("navigation", name="Main").get_by_role("link", name=link)
        )
    on_screen(fleet, fleet.locator('#fleet tr[data-robot="R1"] [data-label="Status"]'))
