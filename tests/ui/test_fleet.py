"""The fleet panel and the floor map."""

import re

import pytest
from django.utils import timezone

from robots.models import Resource, Robot
from scheduling.models import Task
from tests import factories
from tests.factories import lease_acquire
from tests.scheduling.conftest import request, robot_ready


def row_of(html: str, code: str) -> str:
    return re.search(rf'<tr data-robot="{code}".*?</tr>', html, re.S).group(0)


def cell(row: str, field: str) -> str:
    text = re.search(rf'data-field="{field}">(.*?)</td>', row, re.S).group(1)
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", text)).strip()


def test_it_shows_each_robots_presence_status_place_battery_load_task_and_last_seen(
    nurse_client, site
):
    r1 = robot_ready(factories.robot_create(site, "R1"), at="1F-PHARM", battery=0.83, load=1)
    Robot.objects.filter(pk=r1.pk).update(status="moving", paused_by_operator=True)
    factories.robot_create(site, "R2")
    task = request(site)
    Task.objects.filter(pk=task.pk).update(robot=r1, status="acknowledged")

    html = nurse_client.get("/fleet/").content.decode()

    r1_row = row_of(html, "R1")
    assert cell(r1_row, "presence") == "Online"
    assert cell(r1_row, "status") == "Moving held by operator"
    assert cell(r1_row, "place") == "1F · Pharmacy"
    assert cell(r1_row, "battery") == "83 %"
    assert cell(r1_row, "load") == "1 / 4"
    assert cell(r1_row, "tasks") == task.code
    seen = timezone.localtime(Robot.objects.get(pk=r1.pk).last_seen_at).strftime("%H:%M:%S")
    assert cell(r1_row, "last_seen") == seen
    r2_row = row_of(html, "R2")
    assert (cell(r2_row, "presence"), cell(r2_row, "last_seen")) == ("Offline", "never")


def test_it_draws_the_selected_floor_with_its_robots(nurse_client, site):
    robot_ready(factories.robot_create(site, "R1"), at="2F-LAB")
    robot_ready(factories.robot_create(site, "R2"), at="1F-PHARM")

    html = nurse_client.get("/fleet/?floor=2F").content.decode()

    svg = re.search(r'<svg id="floor-map".*?</svg>', html, re.S).group(0)
    assert 'data-waypoint="2F-LAB"' in svg
    assert "<title>Laboratory (2F-LAB)" in svg
    assert 'data-waypoint="1F-PHARM"' not in svg  # another floor
    assert "waiting area of DOOR-2F" in svg
    assert 'data-robot="R1"' in svg
    assert 'data-robot="R2"' not in svg
    assert '<option value="2F" selected>' in html


def test_it_shows_the_floor_most_robots_are_on_by_default(nurse_client, site):
    robot_ready(factories.robot_create(site, "R1"), at="2F-LAB")

    html = nurse_client.get("/fleet/").content.decode()

    assert 'data-floor="2F"' in html


def test_it_shows_who_holds_and_who_waits_for_each_resource(nurse_client, site):
    r1 = robot_ready(factories.robot_create(site, "R1"), at="1F-ELEV-WAIT")
    r2 = robot_ready(factories.robot_create(site, "R2"), at="1F-ELEV-WAIT")
    elevator = Resource.objects.get(site=site, code="ELEV")
    lease_acquire(robot=r1, resource=elevator, request_id="q-1", to_floor="2F")
    lease_acquire(robot=r2, resource=elevator, request_id="q-2", to_floor="3F")

    html = nurse_client.get("/fleet/").content.decode()

    resource = re.search(r'<tr data-resource="ELEV">.*?</tr>', html, re.S).group(0)
    holder, waiting, wait = re.findall(r"<td>(.*?)</td>", resource, re.S)
    assert ">R1</a>" in holder
    assert "granted" in holder
    assert "1. <a" in waiting
    assert re.fullmatch(r"about \d+ s", wait)  # resources.leases.resource_wait_estimate
    assert ">R2</a>" in waiting


def test_it_answers_404_for_an_unknown_floor(nurse_client, site):
    assert nurse_client.get("/fleet/?floor=99F").status_code == 404


@pytest.mark.parametrize("robots", [1, 6])
def test_it_renders_the_fleet_page_in_constant_queries(
    nurse_client, site, robots, django_assert_num_queries
):
    for n in range(robots):
        robot = robot_ready(factories.robot_create(site, f"R{n + 1}"), at="1F-PHARM")
        task = request(site)
        Task.objects.filter(pk=task.pk).update(robot=robot, status="assigned")
    nurse_client.get("/fleet/")  # the site map is cached from now on

    # session, user, the user's groups, sites, the user's sites, robots, their tasks, leases,
    # resources in use (none: no wait to estimate), open alerts; for the lift and door panels:
    # the resources' service, their devices, the floors each lift serves
    with django_assert_num_queries(13):
        assert nurse_client.get("/fleet/").content.count(b"<tr data-robot=") == robots
