"""The floor editor in Chromium: an administrator draws a station and an edge, sees the diff
and publishes; a nurse orders a delivery there at once; an invalid draft is refused with every
problem named and the live map unchanged. A station's name in Korean is given beside its own."""

import pytest
from playwright.sync_api import expect

from maps.models import MapDraft
from robots.models import Site, Waypoint
from scheduling.models import Task
from tests.browser.conftest import TABLET

pytestmark = pytest.mark.browser

EDITOR = "/maps/tiny/edit"


def editor(open_page, user, **options):
    page = open_page(user, EDITOR, live=False, **options)
    expect(page.locator("#editor-status")).to_have_text("Draft loaded.")
    return page


def set_field(page, selector: str, value: str):
    page.locator(selector).fill(value)
    page.locator(selector).press("Tab")  # a change event, as a person leaving the field


def test_it_publishes_a_new_station_and_edge_that_a_nurse_orders_to_at_once(
    open_page, staff, nurse, site
):
    page = editor(open_page, staff)
    page.locator("#editor-floor").select_option("2F")
    page.get_by_label("Add waypoint").check()
    page.locator("#editor-map").click(position={"x": 40, "y": 40})
    expect(page.locator("#wp-code")).to_have_value("2F-WP-1")

    set_field(page, "#wp-code", "2F-XRAY")
    set_field(page, "#wp-name", "X-ray")
    set_field(page, "#wp-name-ko", "영상의학과 접수")
    page.locator("#wp-kind").select_option("station")
    set_field(page, "#wp-x", "30")
    set_field(page, "#wp-y", "0")
    page.locator("#wp-connect").select_option("2F-ELEV-WAIT")
    page.get_by_role("button", name="Add edge").click()
    expect(page.locator("#wp-edges")).to_contain_text("2F-XRAY – 2F-ELEV-WAIT")
    expect(page.locator('#editor-map [data-waypoint="2F-XRAY"] .wp-station')).to_be_attached()
    page.get_by_role("button", name="Check the draft").click()

    changes = page.locator("#check-changes")
    expect(changes).to_contain_text("station added: 2F-XRAY (X-ray)")
    expect(changes).to_contain_text("edge added: 2F-XRAY – 2F-ELEV-WAIT")
    expect(page.locator("#check-problems")).to_have_text("None: the draft is valid.")
    page.get_by_label("Note for the history").fill("X-ray reception opens")
    page.get_by_role("button", name="Publish").click()
    expect(page.locator("#publish-result")).to_have_text("Published version 2.")
    assert Site.objects.get(pk=site.pk).map_version == 2
    published = Waypoint.objects.get(code="2F-XRAY")
    assert (published.kind, published.names) == ("station", {"ko": "영상의학과 접수"})

    order = open_page(nurse, "/")
    order.get_by_label("Sender").fill("Pharmacy")
    order.get_by_label("Receiver").fill("X-ray reception")
    order.get_by_label("Contents").fill("Contrast agent")
    order.get_by_label("Pick-up").fill("Pharmacy")
    order.get_by_label("Drop-off").fill("X-ray")
    order.get_by_role("button", name="Request delivery").click()
    expect(order.locator("#schedule")).to_contain_text("Contrast agent")
    task = Task.objects.get(contents="Contrast agent")
    assert [s.waypoint.code for s in task.stops.order_by("index")] == ["1F-PHARM", "2F-XRAY"]


BROKEN = """\
site: tiny
floors:
  - code: 1F
    level: 1
    waypoints:
      - {code: 1F-DOCK-1, x: 0, y: 0, kind: dock}
      - {code: 1F-HALL, x: 10, y: 0}
      - {code: 1F-HALL, x: 12, y: 0}
    edges:
      - [1F-DOCK-1, 1F-HALL]
      - [1F-HALL, 1F-GONE]
"""


def test_it_refuses_an_uploaded_draft_naming_every_problem_and_keeps_the_live_map(
    open_page, staff, site, tmp_path
):
    page = editor(open_page, staff)
    broken = tmp_path / "broken.yaml"
    broken.write_text(BROKEN)

    page.locator("#editor-upload").set_input_files(str(broken))
    expect(page.locator("#editor-status")).to_contain_text("broken.yaml is now the draft")
    page.get_by_role("button", name="Publish").click()

    expect(page.locator("#publish-result")).to_have_text(
        "Not published: 2 problem(s). The live map is unchanged."
    )
    problems = page.locator("#check-problems li")
    expect(problems).to_have_text(
        [
            "document.floors[0].waypoints[2].code: duplicate code '1F-HALL' "
            "(also floors[0].waypoints[1])",
            "document.floors[0].edges[1]: unknown waypoint '1F-GONE'",
        ]
    )
    assert Site.objects.get(pk=site.pk).map_version == 1
    assert Waypoint.objects.filter(site=site).count() == 15


def test_it_moves_a_waypoint_with_the_arrow_keys_at_tablet_width(open_page, staff, site):
    page = editor(open_page, staff, viewport=TABLET)
    page.locator("#editor-floor").select_option("1F")
    page.get_by_role("button", name="1F-HALL (plain)").click()
    expect(page.locator("#wp-x")).to_have_value("10")

    page.locator("#editor-map").focus()
    page.keyboard.press("ArrowRight")
    page.keyboard.press("Shift+ArrowUp")
    expect(page.locator("#wp-x")).to_have_value("11")
    expect(page.locator("#wp-y")).to_have_value("0.1")
    page.get_by_role("button", name="Save draft").click()

    expect(page.locator("#editor-status")).to_have_text("Draft saved (revision 2).")
    floor = next(f for f in MapDraft.objects.get(site=site).document["floors"] if f["code"] == "1F")
    hall = next(wp for wp in floor["waypoints"] if wp["code"] == "1F-HALL")
    assert (hall["x"], hall["y"]) == (11, 0.1)
    overflow = page.evaluate("document.documentElement.scrollWidth > window.innerWidth")
    assert not overflow, "the editor fits a tablet's width"


def test_it_reports_no_change_for_an_untouched_draft_and_guards_the_edits(open_page, staff, site):
    page = editor(open_page, staff)
    page.get_by_role("button", name="Check the draft").click()
    expect(page.locator("#check-changes")).to_have_text("None: the draft is the live map.")

    # A station without a name would reach nurses as its code: Check names the problem.
    page.locator("#editor-floor").select_option("2F")
    page.get_by_label("Add waypoint").check()
    page.locator("#editor-map").click(position={"x": 40, "y": 40})
    page.locator("#wp-kind").select_option("station")
    expect(page.locator("#editor-status")).to_have_text("Unsaved changes.")

    # Leaving with unsaved edits asks first; staying keeps them.
    asked = []
    page.once("dialog", lambda dialog: (asked.append(dialog.type), dialog.dismiss()))
    page.evaluate("location.assign('/')")
    expect(page.locator("#wp-code")).to_have_value("2F-WP-1")
    assert asked == ["beforeunload"]

    page.get_by_role("button", name="Check the draft").click()
    expect(page.locator("#check-problems")).to_contain_text("station '2F-WP-1' needs a name")

    # Discarding asks first: dismissed, the draft keeps its edits; accepted, it is the live map.
    messages = []
    page.once("dialog", lambda dialog: (messages.append(dialog.message), dialog.dismiss()))
    page.get_by_role("button", name="Discard the draft’s edits").click()
    assert "Discard every edit of the draft" in messages[0]
    assert any(
        wp["code"] == "2F-WP-1"
        for floor in MapDraft.objects.get(site=site).document["floors"]
        for wp in floor["waypoints"]
    )
    page.once("dialog", lambda dialog: dialog.accept())
    page.get_by_role("button", name="Discard the draft’s edits").click()
    expect(page.locator("#editor-status")).to_have_text("The draft is the live map again.")
