"""A secure delivery end to end in Chromium: the nurse orders it and sees its PIN, again on the
delivery's page until it is delivered (nobody else does there), a robot carries it locked, the
receiving station's page announces it with its PIN (never in a live event), the PIN opens it
(checked on the robot's side, offline), and the history and the CSV show the custody chain.
Wrong PINs keep another one locked and alert an operator, live."""

import re

import pytest
from django.test import Client
from django.utils import timezone
from playwright.sync_api import expect

from robots.models import Robot, SiteMembership, Waypoint
from robotsim.client import pin_check
from scheduling.models import Task
from tests import factories
from tests.conftest import RobotHttp
from tests.scheduling.conftest import event, request

pytestmark = pytest.mark.browser

LOCKING = [{"code": "A", "lockable": True}, {"code": "B", "lockable": True}]
AT_PHARMACY = {"floor": "1F", "waypoint": "1F-PHARM", "status": "waiting_load"}
AT_WARD = {"floor": "3F", "waypoint": "3F-WARD", "status": "waiting_unload"}


def plan_of(reply: dict) -> dict:
    [plan] = [m for m in reply["messages"] if m["type"] == "plan"]
    return plan


def unit_member(site, username: str, station: str):
    """A nurse of the site whose unit is `station`: its staff."""
    user = factories.user_create(username, "nurse", sites=[site])
    unit = Waypoint.objects.get(site=site, code=station)
    SiteMembership.objects.filter(user=user, site=site).update(unit=unit)
    return user


def test_a_secure_delivery_from_order_to_custody_record(
    open_page, page_servers, nurse, operator, robot, site
):
    Robot.objects.filter(pk=robot.pk).update(compartments=LOCKING)
    bot = RobotHttp(page_servers.http, robot)
    bot.heartbeat(1)  # R1 online at its dock

    page = open_page(nurse, "/")
    page.get_by_label("Sender").fill("Pharmacy")
    page.get_by_label("Receiver").fill("Ward 3")
    page.get_by_label("Contents").fill("Morphine 10 mg")
    page.get_by_label("Pick-up").fill("Pharmacy")
    page.get_by_label("Drop-off").fill("Ward 3")
    page.get_by_label("Secure (PIN)").check()
    page.get_by_role("button", name="Request delivery").click()
    shown = page.get_by_text(re.compile(r"PIN for T-\d+: \d{8}"))
    expect(shown).to_be_visible()
    pin = re.search(r"PIN for T-\d+: (\d{8})", shown.inner_text()).group(1)
    task = Task.objects.get()
    assert task.secure
    page.reload()
    expect(page.get_by_text(pin)).to_have_count(0)  # not in the schedule
    page.goto(f"/deliveries/{task.code}/")
    expect(page.locator("[data-pin]")).to_have_text(pin)  # the requester's again
    others = open_page(operator, f"/deliveries/{task.code}/", live=False)
    expect(others.locator("h1")).to_contain_text(task.code)
    expect(others.get_by_text(pin)).to_have_count(0)

    ward_nurse = unit_member(site, "lee", "3F-WARD")
    elsewhere = open_page(operator, f"/stations/3F-WARD/?site={site.code}", live=False)
    expect(elsewhere.locator("#incoming")).to_contain_text(task.code)
    expect(elsewhere.get_by_text(pin)).to_have_count(0)  # not of the receiving unit
    station = open_page(ward_nurse, f"/stations/3F-WARD/?site={site.code}")  # the receiving unit
    frames = []
    station.on("websocket", lambda ws: ws.on("framereceived", lambda frame: frames.append(frame)))
    station.reload()
    expect(station.locator("#live-status")).to_have_text("Live")
    station.evaluate("window.notReloaded = true")
    plan = plan_of(bot.heartbeat(2, state=AT_PHARMACY))
    secure = plan["tasks"][task.code]["secure"]
    assert pin not in str(plan)
    loaded = event("loaded", task.code, 0, compartment="A", opened_with="badge", opened_by="b-7")
    bot.heartbeat(3, state=AT_PHARMACY, acks=[plan["id"]], events=[loaded])
    bot.heartbeat(4, state=AT_WARD, events=[event("arrived", task.code, 1)])

    announcement = station.locator(".announce-here")
    expect(announcement).to_contain_text(
        f"R1 is at Ward 3 with Morphine 10 mg {task.code}: enter the PIN {pin} at the robot"
    )
    announced = re.compile(r"^[1-9]\d*$")  # counted (and chimed) as it appeared
    expect(station.locator("[data-station-page]")).to_have_attribute("data-announced", announced)
    assert station.evaluate("window.notReloaded") is True

    # At the robot, offline: a mistyped PIN, then the right one.
    wrong = "000000" if pin != "000000" else "111111"
    assert not pin_check(wrong, secure)
    assert pin_check(pin, secure)
    opened = event("unloaded", task.code, 1, compartment="A", opened_with="pin", failed_attempts=1)
    bot.heartbeat(5, state=AT_WARD, events=[opened, event("task_completed", task.code)])
    expect(station.locator(".announce-here")).to_have_count(0)
    assert frames
    assert not [frame for frame in frames if pin in str(frame)]
    page.reload()
    expect(page.locator("h1")).to_contain_text(task.code)
    expect(page.get_by_text(pin)).to_have_count(0)  # handed over: not shown any more

    history = open_page(nurse, f"/deliveries/{task.code}/")
    custody = history.locator("table.custody")
    expect(custody).to_contain_text("Loaded")
    expect(custody).to_contain_text("Handed over")
    expect(history.locator("table.history")).to_contain_text(
        "Handed over at Ward 3 from compartment A, opened with the delivery's PIN after 1 wrong PIN"
    )
    client = Client()
    client.force_login(operator)
    today = timezone.localdate().isoformat()
    rows = client.get(f"/custody.csv?from={today}&to={today}").content.decode().splitlines()
    assert [row.split(",")[5] for row in rows[1:]] == ["Loaded", "Handed over"]


def test_wrong_pins_keep_it_locked_and_an_operator_sees_the_alert_live(
    open_page, page_servers, operator, robot, site
):
    Robot.objects.filter(pk=robot.pk).update(compartments=LOCKING)
    bot = RobotHttp(page_servers.http, robot)
    bot.heartbeat(1)
    task = request(
        site, secure=True, dropoffs=("3F-WARD",), contents="Midazolam", allocate_now=True
    )
    page = open_page(operator, "/fleet/")
    bot.heartbeat(2, state=AT_PHARMACY, events=[event("loaded", task.code, 0, compartment="B")])

    locked = event("compartment_locked", task.code, 1, compartment="B", failed_attempts=3)
    bot.heartbeat(3, state=AT_WARD, events=[locked])

    alert = page.locator("#alerts").filter(has_text="kept locked")
    expect(alert).to_contain_text("Compartment B kept locked at Ward 3 after 3 wrong PINs")
    task.refresh_from_db()
    assert task.status == "picked_up"


def test_the_requester_re_sends_the_pin_to_the_receiving_units_staff(
    open_page, page_servers, nurse, operator, robot, site
):
    Robot.objects.filter(pk=robot.pk).update(compartments=LOCKING)
    RobotHttp(page_servers.http, robot).heartbeat(1)
    task = request(site, secure=True, dropoffs=("3F-WARD",), user=nurse, allocate_now=True)
    pin = task.pin_plain
    ward_nurse = unit_member(site, "lee", "3F-WARD")
    other_ward = unit_member(site, "cho", "2F-LAB")
    station = open_page(ward_nurse, f"/stations/3F-WARD/?site={site.code}")
    frames = []
    station.on("websocket", lambda ws: ws.on("framereceived", lambda frame: frames.append(frame)))
    station.reload()
    expect(station.locator("#live-status")).to_have_text("Live")
    watching = open_page(operator, f"/stations/3F-WARD/?site={site.code}")

    mine = open_page(nurse, f"/deliveries/{task.code}/", live=False)
    mine.get_by_role("button", name="Re-send the PIN to the receiving station").click()
    expect(mine.locator(".messages")).to_contain_text(
        f"The PIN of {task.code} is shown again on the receiving station's page"
    )

    notice = station.locator(f"[data-pin-resent='{task.code}']")
    expect(notice).to_contain_text(f"re-sent to this station by the person who ordered it: {pin}")
    expect(watching.locator(f"[data-pin-resent='{task.code}']")).to_contain_text(
        "its unit's staff, signed in, see it here"
    )
    expect(watching.get_by_text(pin)).to_have_count(0)
    another = open_page(other_ward, f"/stations/3F-WARD/?site={site.code}", live=False)
    expect(another.locator(f"[data-pin-resent='{task.code}']")).to_be_visible()
    expect(another.get_by_text(pin)).to_have_count(0)
    assert frames
    assert not [frame for frame in frames if pin in str(frame)]
    history = Client()
    history.force_login(operator)
    assert pin not in history.get(f"/deliveries/{task.code}/").content.decode()


def test_only_the_requester_may_re_send_a_pin(client, nurse, operator, robot, site):
    task = request(site, secure=True, dropoffs=("3F-WARD",), user=nurse, allocate_now=True)
    client.force_login(operator)

    client.post(f"/deliveries/{task.code}/pin-resend")

    task.refresh_from_db()
    assert task.pin_resent_at is None
