"""A fire alarm and a lift priority seen from a nurse's page: the notice appears at once, with
no reload and nothing to acknowledge it away, and goes with the all-clear or the release."""

import pytest
from playwright.sync_api import expect

from robots.models import Resource
from scheduling.services import emergency_end, emergency_start, resource_operator_set_priority

pytestmark = pytest.mark.browser


def test_the_fire_alarm_notice_shows_on_a_nurses_page_at_once_and_goes_with_the_all_clear(
    open_page, nurse, operator, site
):
    page = open_page(nurse, "/")
    page.evaluate("window.notReloaded = true")
    notice = page.locator("#alerts .alert-fire_alarm")
    expect(notice).to_have_count(0)

    emergency_start(site=site, floors=["3F"], reason="drill", via="operator", by=operator)

    expect(notice).to_contain_text("Fire alarm on floors 3F, started by park (drill)")
    expect(notice).to_have_attribute("role", "alert")
    expect(notice.get_by_role("button")).to_have_count(0)  # no Acknowledge for anyone

    emergency_end(site=site, via="operator", by=operator)

    expect(notice).to_have_count(0)
    assert page.evaluate("window.notReloaded") is True


def test_a_lift_priority_shows_on_a_nurses_page_until_it_is_released(
    open_page, nurse, operator, site
):
    page = open_page(nurse, "/")
    notice = page.locator("#alerts .alert-lift_priority")
    lift = Resource.objects.get(site=site, code="ELEV")

    resource_operator_set_priority(resource=lift, on=True, by=operator, reason="code blue")

    expect(notice).to_contain_text("ELEV is held for an emergency team by park: code blue")
    resource_operator_set_priority(resource=lift, on=False, by=operator)
    expect(notice).to_have_count(0)
