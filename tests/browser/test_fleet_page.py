"""The fleet panel, floor map and robot page in Chromium, kept live over the websocket."""

import pytest
from playwright.sync_api import expect

from robots.alerts import alert_raise
from robots.models import AlertKind
from tests.conftest import RobotHttp

pytestmark = pytest.mark.browser

AT_THE_LAB = {"status": "moving", "floor": "2F", "waypoint": "2F-LAB", "x": 20.0, "y": 28.0}


@pytest.fixture
def robot_http(page_servers, robot):
    return RobotHttp(page_servers.http, robot)


def fleet_row(page, code: str):
    return page.locator(f'#fleet tr[data-robot="{code}"]')


def test_it_changes_a_robots_row_live_when_it_heartbeats(open_page, nurse, operator, robot_http):
    open_page(operator, "/")  # someone else is ordering meanwhile
    page = open_page(nurse, "/fleet/?floor=2F")  # a second browser context
    page.evaluate("window.notReloaded = true")
    row = fleet_row(page, "R1")
    expect(row.locator('[data-field="presence"]')).to_have_text("Offline")

    robot_http.heartbeat(1, state={**AT_THE_LAB, "battery": 0.83, "load": 2})

    expect(row.locator('[data-field="presence"]')).to_have_text("Online")
    expect(row.locator('[data-field="status"]')).to_have_text("Moving")
    expect(row.locator('[data-field="place"]')).to_have_text("2F · Laboratory")
    expect(row.locator('[data-field="battery"]')).to_have_text("83 %")
    expect(row.locator('[data-field="load"]')).to_have_text("2 / 4")
    expect(page.locator('#map-robots [data-robot="R1"]')).to_be_attached()  # on the map
    assert page.evaluate("window.notReloaded") is True


def test_it_shows_live_that_a_robot_was_sent_to_charge_and_when_it_is_charged(
    open_page, nurse, robot_http
):
    page = open_page(nurse, "/fleet/?floor=2F")
    page.evaluate("window.notReloaded = true")
    status = fleet_row(page, "R1").locator('[data-field="status"]')
    robot_http.heartbeat(1, state={**AT_THE_LAB, "battery": 0.9})
    expect(status).to_have_text("Moving")

    robot_http.heartbeat(2, state={**AT_THE_LAB, "battery": 0.1})  # below the threshold

    expect(status.locator('[data-badge="charge"]')).to_have_text(
        "sent to charge: no tasks until charged"
    )
    robot_http.heartbeat(3, state={**AT_THE_LAB, "status": "charging", "battery": 0.95})
    expect(status).to_have_text("Charging")
    expect(status.locator('[data-badge="charge"]')).to_have_count(0)
    assert page.evaluate("window.notReloaded") is True


def test_it_moves_a_robot_on_the_map_and_off_it_to_another_floor(open_page, nurse, robot_http):
    page = open_page(nurse, "/fleet/?floor=2F")
    marker = page.locator('#map-robots [data-robot="R1"]')

    # 2F of the tiny site spans x 20..20, y 10..30; drawn with a 6 m margin, y downwards.
    robot_http.heartbeat(1, state=AT_THE_LAB)
    expect(marker).to_have_attribute("style", "transform: translate(6px, 8px);")
    robot_http.heartbeat(2, state={**AT_THE_LAB, "y": 12.0})
    expect(marker).to_have_attribute("style", "transform: translate(6px, 24px);")
    robot_http.heartbeat(3, state={**AT_THE_LAB, "floor": "1F", "waypoint": "1F-ELEV-WAIT"})

    expect(marker).to_have_count(0)
    expect(fleet_row(page, "R1").locator('[data-field="place"]')).to_contain_text("1F")


def test_it_sends_an_operators_pause_in_the_robots_next_heartbeat(open_page, operator, robot_http):
    page = open_page(operator, "/robots/R1/")

    page.get_by_role("button", name="Pause").click()

    expect(page.get_by_text("Pause sent to R1.")).to_be_visible()
    expect(page.locator('[data-field="status"]')).to_contain_text("held by operator")
    reply = robot_http.heartbeat(1)
    actions = [m["action"] for m in reply["messages"] if m["type"] == "action"]
    assert actions == ["pause"]


def test_it_reads_the_state_again_after_the_websocket_server_restarts(
    open_page, page_servers, nurse, robot_http
):
    page = open_page(nurse, "/fleet/")
    status = page.locator("#live-status")

    page_servers.ws.stop()
    expect(status).to_have_text("Reconnecting…")
    robot_http.heartbeat(1, state=AT_THE_LAB)  # its event is lost: nobody listens
    page_servers.ws.start()

    # daphne's restart and the page's back-off take longer on a loaded machine: a deadline.
    expect(status).to_have_text("Live", timeout=30_000)
    expect(fleet_row(page, "R1").locator('[data-field="status"]')).to_have_text("Moving")


def test_it_shows_alerts_live_until_an_operator_acknowledges_them(
    open_page, site, robot, nurse, operator
):
    nurses_page = open_page(nurse, "/")
    operators_page = open_page(operator, "/fleet/")

    alert_raise(
        site_id=site.pk,
        kind=AlertKind.OFFLINE_WITH_LOAD,
        key="offline-with-load:R1",
        message="R1 went offline carrying T-0042",
        robot=robot,
    )

    def alert(page):
        return page.locator("#alerts").get_by_text("R1 went offline carrying T-0042", exact=True)

    for page in (nurses_page, operators_page):
        expect(alert(page)).to_be_visible()
    expect(nurses_page.get_by_role("button", name="Acknowledge")).to_have_count(0)
    operators_page.get_by_role("button", name="Acknowledge").click()
    for page in (nurses_page, operators_page):
        expect(alert(page)).to_have_count(0)
