"""A live part re-read while a person types in it: the fleet page's resources panel patches
what changed and keeps the operator's focus, caret and typed reason (static/js/live.js)."""

import pytest
from playwright.sync_api import expect

from building.services import devices_ensure
from robots.models import Resource
from ui.live.publish import publish_on_commit

pytestmark = pytest.mark.browser

REASON = "cleaning the floor of lift A"  # more letters than live events: one typed per event


def test_it_keeps_a_typed_reason_through_twenty_live_events(open_page, operator, site):
    devices_ensure(site=site)
    page = open_page(operator, "/fleet/?floor=2F")
    lift = page.locator('#resources tr[data-resource="ELEV"]')
    reason = lift.get_by_label("Reason for taking ELEV out of service")
    reason.click()
    page.keyboard.type(REASON[:8])

    for letter in REASON[8:28]:
        with page.expect_response(lambda response: "state.json" in response.url):
            publish_on_commit(site_id=site.pk, kind="resource", data={"resource": "ELEV"})
        page.keyboard.type(letter)

    expect(reason).to_have_value(REASON)
    expect(reason).to_be_focused()
    page.once("dialog", lambda dialog: dialog.accept())
    page.keyboard.press("Enter")
    expect(lift.locator('[data-service="out"]')).to_have_text("Out of service")
    expect(lift).to_contain_text(REASON)
    assert Resource.objects.get(site=site, code="ELEV").out_of_service_reason == REASON
