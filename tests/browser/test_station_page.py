"""The receiving station's page in Chromium: its sound can be turned off, and stays off; with
it off an arrival is still announced, silently. A nurse pins "My station", and every page's
menu then leads back to it."""

import re

import pytest
from playwright.sync_api import expect

from scheduling.services import task_allocate
from tests.conftest import RobotHttp
from tests.scheduling.conftest import event, request

pytestmark = pytest.mark.browser

AT_PHARMACY = {"floor": "1F", "waypoint": "1F-PHARM", "status": "waiting_load"}
AT_WARD = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}
# Counts the chimes the page plays: an AudioContext that makes no sound.
COUNT_CHIMES = """
window.chimes = 0;
window.AudioContext = class {
  constructor() { window.chimes += 1; this.currentTime = 0; this.destination = {}; }
  createOscillator() { return { frequency: {}, connect: (next) => next, start() {}, stop() {} }; }
  createGain() {
    const gain = { setValueAtTime() {}, exponentialRampToValueAtTime() {} };
    return { gain, connect: (next) => next };
  }
};
"""
ANNOUNCED = re.compile(r"^[1-9]\d*$")


def station_page(open_page, nurse, site):
    page = open_page(nurse, f"/stations/3F-WARD/?site={site.code}")
    page.add_init_script(COUNT_CHIMES)
    page.reload()  # with the chimes counted from the start
    expect(page.locator("#live-status")).to_have_text("Live")
    return page


def test_the_sound_can_be_turned_off_stays_off_and_silences_arrivals(
    open_page, page_servers, nurse, robot, site
):
    bot = RobotHttp(page_servers.http, robot)
    bot.heartbeat(1)
    first = request(site, dropoffs=("3F-WARD",), contents="Blood sample")
    assert task_allocate(task_id=first.pk)
    bot.heartbeat(2, state=AT_PHARMACY, events=[event("loaded", first.code, 0)])
    page = station_page(open_page, nurse, site)
    sound = page.get_by_role("button", name=re.compile("^Sound"))
    expect(sound).to_have_text("Sound on")
    expect(sound).to_have_attribute("aria-pressed", "true")

    bot.heartbeat(3, state=AT_WARD, events=[event("arrived", first.code, 1)])
    expect(page.locator(f'[data-announce="here-{first.code}-1"]')).to_be_visible()
    page.wait_for_function("window.chimes > 0")  # heard, with the sound on

    sound.click()
    expect(sound).to_have_text("Sound off")
    expect(sound).to_have_attribute("aria-pressed", "false")
    page.reload()
    expect(page.locator("#live-status")).to_have_text("Live")
    expect(sound).to_have_text("Sound off")  # kept in this browser

    # R1 fetches a second delivery for the ward and comes back with it: a new announcement.
    second = request(site, dropoffs=("3F-WARD",), contents="Urine sample")
    assert task_allocate(task_id=second.pk)
    bot.heartbeat(4, state=AT_PHARMACY, events=[event("loaded", second.code, 0)])
    bot.heartbeat(5, state=AT_WARD, events=[event("arrived", second.code, 1)])
    expect(page.locator(f'[data-announce="here-{second.code}-1"]')).to_be_visible()
    expect(page.locator("[data-station-page]")).to_have_attribute("data-announced", ANNOUNCED)
    assert page.evaluate("window.chimes") == 0  # announced, silently

    sound.click()
    expect(sound).to_have_text("Sound on")


def test_a_nurse_pins_my_station_and_the_menu_leads_back_to_it(open_page, nurse, site):
    page = station_page(open_page, nurse, site)
    pin = page.get_by_role("button", name="Make this my station")

    pin.click()

    expect(page.get_by_role("button", name="This is my station")).to_be_disabled()
    page.goto("/")
    mine = page.get_by_role("link", name="My station: Ward 3")
    expect(mine).to_be_visible()
    mine.click()
    expect(page).to_have_url(re.compile(r"/stations/3F-WARD/\?site="))
    expect(page.get_by_role("heading", name="Ward 3")).to_be_visible()
    expect(page.get_by_role("button", name="This is my station")).to_be_disabled()  # remembered

    page.goto(f"/stations/2F-LAB/?site={site.code}")  # another station: offered, not pinned
    expect(page.get_by_role("button", name="Make this my station")).to_be_enabled()
    expect(page.get_by_role("link", name="My station: Ward 3")).to_be_visible()
