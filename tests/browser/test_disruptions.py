"""A nurse's row says, live, what happens to her delivery's robot: held, recalled, replaced."""

import pytest
from django.utils import timezone
from playwright.sync_api import expect

from robots.models import Waypoint
from scheduling.services import robot_action, task_allocate
from tests import factories
from tests.conftest import RobotHttp
from tests.scheduling.conftest import request, robot_ready

pytestmark = pytest.mark.browser


def test_a_nurses_row_changes_live_when_her_robot_is_paused_recalled_or_replaced(
    open_page, page_servers, nurse, operator, robot, site
):
    RobotHttp(page_servers.http, robot).heartbeat(1)  # R1 online at its dock
    task = request(site, user=nurse, contents="Insulin")
    assert task_allocate(task_id=task.pk)
    page = open_page(nurse, "/")
    page.evaluate("window.notReloaded = true")
    row = page.locator(f'#schedule tr[data-task="{task.code}"]')
    expect(row).to_contain_text("R1")
    expect(row.locator('[data-field="eta"] time')).to_have_count(1)

    robot_action(robot=robot, action="pause", by=operator)
    expect(row.locator('[data-field="notice"]')).to_have_text("Held by an operator")
    expect(row.locator('[data-field="eta"]')).to_have_text("on hold")

    robot_action(robot=robot, action="resume", by=operator)
    expect(row.locator('[data-field="notice"]')).to_have_count(0)
    expect(row.locator('[data-field="eta"] time')).to_have_count(1)

    robot_action(robot=robot, action="return_to_dock", by=operator)
    expect(row.locator('[data-field="notice"]')).to_have_text(
        "R1 recalled to its dock by an operator: waiting for another robot"
    )
    expect(row.locator('[data-field="eta"]')).to_have_text("—")

    dock = Waypoint.objects.get(site=site, code="1F-DOCK-2")
    robot_ready(factories.robot_create(site, "R2", dock=dock))
    assert task_allocate(task_id=task.pk)
    expect(row.locator('[data-field="notice"]')).to_have_text(
        "R1 recalled to its dock by an operator: reassigned to R2"
    )
    expect(row.locator('[data-field="eta"] time')).to_have_count(1)
    assert page.evaluate("window.notReloaded") is True

    row.get_by_role("link", name=task.code).click()
    history = page.get_by_role("dialog")
    expect(history).to_contain_text("Held by an operator")
    expect(history).to_contain_text("Released by an operator: on its way again")
    expect(history).to_contain_text("R1 recalled to its dock by an operator: reassigned to R2")


def test_a_nurses_eta_changes_live_as_her_robot_reports_progress(
    open_page, page_servers, nurse, robot, site
):
    robot_http = RobotHttp(page_servers.http, robot)
    robot_http.heartbeat(1)  # R1 online at its dock
    task = request(site, user=nurse, contents="Insulin")
    assert task_allocate(task_id=task.pk)
    page = open_page(nurse, "/")
    page.evaluate("window.notReloaded = true")
    # Counts the schedule's re-reads where Playwright can watch it (the CSP forbids eval).
    page.evaluate(
        "document.body.dataset.rereads = 0;"
        "Live.on('state', () => { document.body.dataset.rereads -= -1; })"
    )
    rereads = page.locator("body")
    row = page.locator(f'#schedule tr[data-task="{task.code}"]')
    eta = row.locator('[data-field="eta"] time')
    plan = next(m for m in robot_http.heartbeat(2)["messages"] if m["type"] == "plan")
    robot_http.heartbeat(3, acks=[plan["id"]], state={"plan_version": plan["plan_version"]})
    expect(row.locator('[data-field="status"]')).to_contain_text("Robot on its way")
    expect(rereads).to_have_attribute("data-rereads", "1")  # a new status: re-read
    planned = eta.get_attribute("datetime")

    # At the pharmacy: a history entry, no new status, so no re-read; only new ETAs.
    arrived = {"id": factories.event_id(), "type": "arrived", "task": task.code, "stop": 0}
    state = {"waypoint": "1F-PHARM", "plan_version": plan["plan_version"]}
    robot_http.heartbeat(4, events=[arrived], state=state)

    task.refresh_from_db()
    expect(eta).to_have_attribute("datetime", timezone.localtime(task.eta).isoformat())
    assert timezone.localtime(task.eta).isoformat() != planned
    expect(rereads).to_have_attribute("data-rereads", "1")
    assert page.evaluate("window.notReloaded") is True
