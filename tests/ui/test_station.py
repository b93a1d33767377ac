"""The receiving station's view: what is on its way, and the robot waiting at it, announced."""

from datetime import timedelta

from django.utils import timezone

from scheduling.models import Task
from scheduling.services import task_allocate
from tests import factories
from tests.scheduling.conftest import Beater, event, request, robot_ready


def test_it_announces_a_robot_waiting_at_the_station_and_lists_what_is_coming(nurse_client, site):
    lockable = [{"code": "A", "lockable": True}, {"code": "B"}]
    robot = robot_ready(factories.robot_create(site, "R1", compartments=lockable))
    here = request(site, dropoffs=("3F-WARD",), contents="Blood sample", secure=True)
    coming = request(site, pickups=("2F-LAB",), dropoffs=("3F-WARD",), contents="Kit")
    elsewhere = request(site, contents="Insulin")  # to the laboratory
    for task in (here, coming, elsewhere):
        task_allocate(task_id=task.pk)
    beater = Beater(robot)
    beater.beat(events=[event("loaded", here.code, 0)])
    beater.beat(
        floor="3F",
        waypoint="3F-WARD",
        status="waiting_unload",
        events=[event("arrived", here.code, 1)],
    )
    Task.objects.filter(pk=coming.pk).update(eta=timezone.now() + timedelta(minutes=1))

    html = nurse_client.get(f"/stations/3F-WARD/?site={site.code}").content.decode()

    assert f"R1 is at Ward 3 with Blood sample {here.code}</strong>: enter the PIN" in html
    assert "Waiting <time data-since=" in html
    assert "R1 arrives at about" in html
    assert f"Kit {coming.code}" in html
    assert elsewhere.code not in html
    state = nurse_client.get(
        f"/live/{site.code}/state.json", {"parts": "station", "station": "3F-WARD"}
    ).json()
    assert f"with Blood sample {here.code}" in state["parts"]["station"]


def test_it_lists_stations_and_refuses_a_waypoint_that_is_not_one(nurse_client, site):
    listing = nurse_client.get(f"/stations/?site={site.code}").content.decode()

    assert f'href="/stations/3F-WARD/?site={site.code}"' in listing
    assert nurse_client.get(f"/stations/1F-HALL/?site={site.code}").status_code == 404
    assert nurse_client.get(f"/stations/NOPE/?site={site.code}").status_code == 404
    missing = nurse_client.get(
        f"/live/{site.code}/state.json", {"parts": "station", "station": "NOPE"}
    )
    assert missing.status_code == 404
