"""The deliveries page in Chromium: log in, order by the form's labels, errors, cancel, tablet
width and the keyboard."""

import re

import pytest
from playwright.sync_api import expect

from scheduling.models import Task
from tests import factories
from tests.browser.conftest import TABLET
from tests.scheduling.conftest import request

pytestmark = pytest.mark.browser


def schedule_row(page, text: str):
    return page.locator("#schedule tbody tr").filter(has_text=text)


def test_it_logs_in_with_a_username_and_a_password(open_page, nurse):
    page = open_page(None, "/", live=False)

    expect(page).to_have_url(re.compile(r"/accounts/login/\?next=/$"))
    page.get_by_label("Username").fill("kim")
    page.get_by_label("Password").fill(factories.PASSWORD)
    page.get_by_role("button", name="Log in").click()

    expect(page.get_by_role("heading", name="Request a delivery")).to_be_visible()
    expect(page.locator("#live-status")).to_have_text("Live")


def test_it_orders_a_delivery_by_the_labels_and_shows_it_in_the_schedule(open_page, nurse):
    page = open_page(nurse, "/")

    expect(page.get_by_label("Collection time")).not_to_have_value("")  # now, by default
    page.get_by_label("Sender").fill("Nurse Kim, ward 3")
    page.get_by_label("Receiver").fill("Laboratory reception")
    page.get_by_label("Contents").fill("Blood samples")
    page.get_by_label("Pick-up").fill("Ward 3")
    page.get_by_label("Drop-off").fill("Laboratory")
    page.get_by_label("Priority").select_option("Urgent")
    page.get_by_label("Repeat").select_option("No")
    page.get_by_role("button", name="Request delivery").click()

    row = schedule_row(page, "Blood samples")
    expect(row).to_contain_text("Ward 3 → Laboratory")
    expect(row).to_contain_text("Urgent")
    expect(row).to_contain_text("Due, waiting for a robot")
    task = Task.objects.get()
    assert (task.requester, task.sender, task.priority) == (nurse, "Nurse Kim, ward 3", "urgent")


def test_it_shows_the_error_next_to_the_field_and_creates_nothing(open_page, nurse):
    page = open_page(nurse, "/")

    page.get_by_label("Sender").fill("Nurse Kim")
    page.get_by_label("Receiver").fill("Laboratory")
    page.get_by_label("Contents").fill("Blood samples")
    page.get_by_label("Pick-up").fill("Ward 3")
    page.get_by_label("Drop-off").fill("Nowhere")
    page.get_by_role("button", name="Request delivery").click()

    drop_off = page.get_by_label("Drop-off")
    expect(drop_off).to_have_accessible_description("unknown station 'Nowhere'")
    expect(drop_off).to_have_attribute("aria-invalid", "true")
    expect(drop_off).to_have_value("Nowhere")
    expect(page.get_by_label("Sender")).to_have_value("Nurse Kim")
    assert not Task.objects.exists()


def test_it_adds_drop_offs_for_a_one_to_many_delivery(open_page, nurse):
    page = open_page(nurse, "/")

    page.get_by_label("Sender").fill("Pharmacy")
    page.get_by_label("Receiver").fill("Wards")
    page.get_by_label("Contents").fill("Medication")
    page.get_by_label("Pick-up").fill("Pharmacy")
    page.get_by_label("Drop-off", exact=True).fill("Laboratory")
    page.get_by_role("button", name="Add drop-off").click()
    expect(page.get_by_label("Drop-off 2")).to_be_focused()
    page.get_by_label("Drop-off 2").fill("Ward 3")
    page.get_by_role("button", name="Request delivery").click()

    expect(schedule_row(page, "Medication")).to_contain_text("Pharmacy → Laboratory, Ward 3")


def test_it_cancels_a_delivery_from_the_schedule_table(open_page, nurse, site):
    task = request(site, user=nurse, contents="Insulin")
    page = open_page(nurse, "/")

    row = schedule_row(page, "Insulin")
    row.get_by_role("button", name="Cancel").click()

    expect(page.get_by_text(f"Delivery {task.code} cancelled.")).to_be_visible()
    expect(schedule_row(page, "Insulin")).to_contain_text("Cancelled")
    expect(schedule_row(page, "Insulin").get_by_role("button", name="Cancel")).to_have_count(0)
    task.refresh_from_db()
    assert task.status == "cancelled"


def test_it_updates_the_schedule_live_when_someone_else_orders(open_page, nurse, site):
    page = open_page(nurse, "/")
    page.evaluate("window.notReloaded = true")

    request(site, contents="Sterile gauze")

    expect(schedule_row(page, "Sterile gauze")).to_contain_text("Due, waiting for a robot")
    assert page.evaluate("window.notReloaded") is True


def test_it_opens_a_tasks_history_from_its_row(open_page, nurse, site):
    task = request(site, user=nurse, contents="Insulin")
    page = open_page(nurse, "/")

    schedule_row(page, "Insulin").get_by_text("Insulin").click()  # anywhere on its row

    dialog = page.get_by_role("dialog")
    expect(dialog).to_contain_text("Requested")
    expect(dialog.get_by_role("button", name="Close")).to_be_focused()
    page.keyboard.press("Escape")
    expect(dialog).to_be_hidden()
    expect(page.get_by_role("link", name=task.code)).to_be_focused()


def test_it_fits_the_form_on_a_tablet(open_page, nurse):
    page = open_page(nurse, "/", viewport=TABLET)

    assert page.evaluate("document.documentElement.scrollWidth") <= TABLET["width"]
    form = page.locator("#request-form").bounding_box()
    assert form["x"] >= 0
    assert form["x"] + form["width"] <= TABLET["width"]
    expect(page.get_by_role("button", name="Request delivery")).to_be_in_viewport()


def test_it_takes_an_order_from_the_keyboard_alone(open_page, nurse):
    page = open_page(nurse, "/")

    def tab_to(label: str):
        field = page.get_by_label(label, exact=True)
        for _ in range(30):
            page.keyboard.press("Tab")
            if field.evaluate("element => element === document.activeElement"):
                return
        raise AssertionError(f"Tab never reached {label}")

    for label, text in [
        ("Sender", "Nurse Kim"),
        ("Receiver", "Laboratory"),
        ("Contents", "Urine sample"),
        ("Pick-up", "Ward 3"),
        ("Drop-off", "Laboratory"),
    ]:
        tab_to(label)
        page.keyboard.type(text)
        page.keyboard.press("Escape")  # closes the station suggestions, if open
    page.keyboard.press("Enter")

    expect(schedule_row(page, "Urine sample")).to_contain_text("Ward 3 → Laboratory")
