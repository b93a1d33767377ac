"""The operator's fleet page on the issue's desktop (1366 × 768): the top bar on one line, the
resources table whole (nothing clipped, no sideways scrolling), the floor map's labels apart."""

import pytest
from playwright.sync_api import expect

from tests.conftest import RobotHttp

pytestmark = pytest.mark.browser

LAPTOP = {"width": 1366, "height": 768}
WIDER_THAN_THE_SCREEN = "document.documentElement.scrollWidth > window.innerWidth"
CLIPPED = "(el) => el.scrollWidth > el.clientWidth + 1"


def overlapping(boxes: list[dict]) -> list[tuple]:
    def apart(a, b):
        return (
            a["x"] + a["width"] <= b["x"]
            or b["x"] + b["width"] <= a["x"]
            or a["y"] + a["height"] <= b["y"]
            or b["y"] + b["height"] <= a["y"]
        )

    return [(a, b) for n, a in enumerate(boxes) for b in boxes[n + 1 :] if not apart(a, b)]


def test_the_fleet_page_fits_a_1366_px_screen(open_page, page_servers, operator, robot, site):
    RobotHttp(page_servers.http, robot).heartbeat(1)
    page = open_page(operator, f"/fleet/?site={site.code}", viewport=LAPTOP)

    assert not page.evaluate(WIDER_THAN_THE_SCREEN)
    links = page.get_by_role("navigation", name="Main").get_by_role("link").all()
    tops = {round(link.bounding_box()["y"]) for link in links}
    assert len(tops) == 1, tops  # one line
    header = page.locator("header.topbar").bounding_box()
    account = page.locator("header.topbar .account").bounding_box()
    assert account["y"] + account["height"] <= header["y"] + header["height"]
    assert account["y"] < header["y"] + 0.5 * header["height"]  # beside the links, not below
    table = page.locator("#resources")
    assert not page.locator(".resources-panel .table-scroll").evaluate(CLIPPED)
    assert not page.locator(".resources-panel").evaluate(CLIPPED)
    panel = page.locator(".resources-panel").bounding_box()
    table_box = table.bounding_box()
    assert table_box["x"] + table_box["width"] <= panel["x"] + panel["width"] + 1
    place = page.locator('#fleet tr[data-robot="R1"] [data-field="place"]')
    expect(place.locator(".place-code")).to_have_text("1F-DOCK-1")  # the code, for operators
    labels = [
        box for box in (t.bounding_box() for t in page.locator("#floor-map .wp-label").all()) if box
    ]
    assert overlapping(labels) == []
