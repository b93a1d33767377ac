"""Station search on the request form (static/js/combobox.js): a WAI-ARIA 1.2 combobox that
suggests stations by any part of their name, code or ward, used here by keyboard only."""

import re

import pytest
from playwright.sync_api import expect

from scheduling.models import Task

pytestmark = pytest.mark.browser


def test_a_nurse_finds_and_picks_stations_by_keyboard_only(open_page, nurse):
    page = open_page(nurse, "/")
    pickup = page.get_by_role("combobox", name="Pick-up")
    dropoff = page.get_by_role("combobox", name="Drop-off")
    expect(pickup).to_have_attribute("aria-expanded", "false")
    expect(page.locator("datalist")).to_have_count(0)

    page.get_by_label("Sender").focus()
    page.keyboard.type("Pharmacy")
    page.keyboard.press("Tab")
    page.keyboard.type("Laboratory reception")
    page.keyboard.press("Tab")
    page.keyboard.type("Blood samples")
    pickup.focus()
    page.keyboard.type("ARMA")  # inside the name, any case
    suggestions = page.locator(f"#{pickup.get_attribute('aria-controls')}")
    expect(suggestions).to_have_attribute("role", "listbox")
    expect(pickup).to_have_attribute("aria-expanded", "true")
    expect(suggestions.get_by_role("option")).to_have_text([re.compile(r"^Pharmacy 1F · 1F-PHARM")])
    page.keyboard.press("ArrowDown")
    option = suggestions.get_by_role("option").first
    expect(option).to_have_attribute("aria-selected", "true")
    expect(pickup).to_have_attribute("aria-activedescendant", option.get_attribute("id"))
    page.keyboard.press("Enter")  # takes the suggestion; does not send the form
    expect(pickup).to_have_value("Pharmacy")
    expect(pickup).to_have_attribute("aria-expanded", "false")
    expect(suggestions).to_be_hidden()
    assert not Task.objects.exists()

    dropoff.focus()
    page.keyboard.type("w")
    expect(dropoff).to_have_attribute("aria-expanded", "true")
    page.keyboard.press("Escape")  # closes the list, keeps what was typed
    expect(dropoff).to_have_attribute("aria-expanded", "false")
    expect(dropoff).to_have_value("w")
    page.keyboard.press("Backspace")
    page.keyboard.type("2f-l")  # by its code
    page.keyboard.press("ArrowUp")  # from the end of the list
    page.keyboard.press("Enter")
    expect(dropoff).to_have_value("Laboratory")
    page.keyboard.press("Enter")  # the list is closed: now Enter sends the form

    row = page.locator("#schedule tbody tr").filter(has_text="Blood samples")
    expect(row).to_contain_text("Pharmacy → Laboratory")
    task = Task.objects.get()
    assert [stop.waypoint.code for stop in task.stops.order_by("index")] == ["1F-PHARM", "2F-LAB"]
