"""A robot says which protocol it speaks: declared in the site file, shown on the fleet page and
in the API, otherwise like any other."""

import copy
import re

import pytest

from robots.models import Robot
from robots.sitefile import SiteFileInvalid, site_load
from tests import factories
from tests.ui.conftest import nurse_client, operator_client  # noqa: F401 (fixtures)

pytestmark = pytest.mark.django_db


def site_with(*robots) -> dict:
    data = copy.deepcopy(factories.TINY_SITE)
    data["robots"] = list(robots)
    return data


def test_it_loads_vda5050_robots_from_the_site_file():
    vehicle = {"code": "V1", "dock": "1F-DOCK-1", "protocol": "vda5050"}
    vehicle |= {"manufacturer": "Acme", "serial_number": "SN-7"}
    site_load(data=site_with({"code": "R1", "dock": "1F-DOCK-2"}, vehicle))

    rows = {r.code: (r.protocol, r.manufacturer, r.serial_number) for r in Robot.objects.all()}
    assert rows == {"R1": ("heartbeat", "", ""), "V1": ("vda5050", "Acme", "SN-7")}


LIB_VEHICLE = {
    "pick": {"stationType": "floor", "loadType": "EPAL"},
    "stations": {"2F-LAB": {"drop": {"stationType": "floor-lab", "height": 0.8}}},
    "state_interval": 30,
    "lift_wait_alert": 90,
    "quirks": ["instant_actions_field"],
}


def vda(**fields) -> dict:
    return {
        "code": "V1",
        "dock": "1F-DOCK-1",
        "protocol": "vda5050",
        "manufacturer": "Acme",
        "serial_number": "SN-7",
        **fields,
    }


def test_it_loads_a_vehicles_own_needs_from_the_site_file():
    site_load(data=site_with(vda(vda5050=LIB_VEHICLE)))
    assert Robot.objects.get(code="V1").vda5050 == LIB_VEHICLE


@pytest.mark.parametrize(
    ("robots", "problem"),
    [
        (
            [{"code": "R1", "dock": "1F-DOCK-1", "vda5050": {"state_interval": 30}}],
            "robots[0].vda5050: only for a robot of protocol vda5050",
        ),
        ([vda(vda5050={"quirks": ["flies"]})], "robots[0].vda5050.quirks[0]: one of"),
        ([vda(vda5050={"state_interval": 0})], "robots[0].vda5050.state_interval"),
        ([vda(vda5050={"lift_wait_alert": -5})], "robots[0].vda5050.lift_wait_alert"),
        ([vda(vda5050={"pick": {"loadType": ["EPAL"]}})], "robots[0].vda5050.pick.loadType"),
        ([vda(vda5050={"grab": {}})], "robots[0].vda5050.grab"),
        (
            [vda(vda5050={"stations": {"1F-HALL": {"pick": {}}}})],
            "robots[0].vda5050.stations.1F-HALL: '1F-HALL' is not a station's code",
        ),
        (
            [vda(vda5050={"stations": {"2F-LAB": {"lift": {}}}})],
            "robots[0].vda5050.stations.2F-LAB.lift",
        ),
        (
            [{"code": "V1", "dock": "1F-DOCK-1", "protocol": "vda5050", "manufacturer": "Acme"}],
            "robots[0].serial_number: required for a vda5050 robot",
        ),
        (
            [{"code": "R1", "dock": "1F-DOCK-1", "serial_number": "SN-1"}],
            "robots[0].serial_number: only for a robot of protocol vda5050",
        ),
        (
            [{"code": "R1", "dock": "1F-DOCK-1", "protocol": "mqtt"}],
            "robots[0].protocol",
        ),
        (
            [
                {"code": c, "dock": "1F-DOCK-1", "protocol": "vda5050", "manufacturer": "A"}
                | {"serial_number": "SN-1"}
                for c in ("V1", "V2")
            ],
            "robots[1].serial_number: duplicate vehicle A/SN-1",
        ),
    ],
)
def test_it_refuses_a_robot_declared_wrongly(robots, problem):
    with pytest.raises(SiteFileInvalid) as raised:
        site_load(data=site_with(*robots))
    assert any(problem in text for text in raised.value.problems), raised.value.problems
    assert not Robot.objects.exists()


def test_it_shows_the_protocol_on_the_fleet_page_and_in_the_api(
    operator_client,  # noqa: F811
    nurse_client,  # noqa: F811
    site,
    client,
    staff,
):
    factories.robot_create(site, "R1")
    factories.robot_create(
        site, "V1", protocol="vda5050", manufacturer="Acme", serial_number="SN-7"
    )

    html = operator_client.get("/fleet/").content.decode()
    assert 'data-field="protocol"' not in nurse_client.get("/fleet/").content.decode()
    shown = dict(
        re.findall(r'<tr data-robot="(\w+)".*?data-field="protocol"[^>]*>(\w+)<', html, re.S)
    )
    assert shown == {"R1": "heartbeat", "V1": "vda5050"}

    listed = client.get(
        "/api/v1/robots/", HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}"
    ).json()["results"]
    assert {r["code"]: r["protocol"] for r in listed} == {"R1": "heartbeat", "V1": "vda5050"}
