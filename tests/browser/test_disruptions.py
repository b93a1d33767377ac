"""A nurse's row says, live, what happens to her delivery's robot: held, recalled, replaced."""

import pytest
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
