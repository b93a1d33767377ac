"""The demo's mixed fleet: demo_setup declares a share of the robots VDA 5050 vehicles, and
simulate_fleet runs them over MQTT, where the bridge makes them members of the fleet."""

import json
from io import StringIO

import pytest
from django.core.management import CommandError, call_command

from robots.models import Robot
from tests import factories, servers
from tests.vda5050.conftest import BROKER


@pytest.fixture
def site_file(tmp_path):
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(factories.TINY_SITE))
    return path


def demo_setup(tmp_path, site_file, *extra):
    call_command(
        "demo_setup",
        *("--only", "fleet", "--site-file", str(site_file)),
        *("--fleet-file", str(tmp_path / "fleet.json"), "--server-url", "http://server:8000"),
        *extra,
        stdout=StringIO(),
    )
    return json.loads((tmp_path / "fleet.json").read_text())


@pytest.mark.django_db
def test_demo_setup_declares_the_last_share_of_the_robots_vda5050(tmp_path, site_file, site):
    for code in ("R1", "R2", "R3", "R4"):
        factories.robot_create(site, code)

    fleet = demo_setup(tmp_path, site_file, "--vda5050", "0.5")

    declared = {
        r["code"]: (r["protocol"], r["manufacturer"], r["serial_number"]) for r in fleet["robots"]
    }
    assert declared == {
        "R1": ("heartbeat", "", ""),
        "R2": ("heartbeat", "", ""),
        "R3": ("vda5050", "robotsim", "R3"),
        "R4": ("vda5050", "robotsim", "R4"),
    }
    assert Robot.objects.get(code="R4").protocol == "vda5050"
    assert fleet["mqtt"]["port"] == 1883

    fleet = demo_setup(tmp_path, site_file, "--vda5050", "0")
    assert {r["protocol"] for r in fleet["robots"]} == {"heartbeat"}


@pytest.mark.django_db
def test_simulate_fleet_refuses_to_run_undeclared_robots_as_vda5050(tmp_path, site_file, site):
    factories.robot_create(site, "R1")
    demo_setup(tmp_path, site_file)
    with pytest.raises(CommandError, match="not VDA 5050 robots on the server: R1"):
        call_command("simulate_fleet", "--fleet", str(tmp_path / "fleet.json"), "--vda5050", "1")


@pytest.mark.slow
def test_simulate_fleet_runs_a_mixed_fleet(
    tmp_path, site_file, site, live_server, bridge, interface
):
    for code in ("R1", "R2"):
        factories.robot_create(site, code)
    fleet = demo_setup(tmp_path, site_file, "--vda5050", "0.5")
    fleet["server_url"] = live_server.url
    fleet["ws_url"] = None
    fleet["mqtt"] = {"host": BROKER[0], "port": BROKER[1], "interface": interface}
    (tmp_path / "fleet.json").write_text(json.dumps(fleet))
    out = StringIO()

    call_command(
        "simulate_fleet",
        *("--fleet", str(tmp_path / "fleet.json"), "--duration", "3", "--speedup", "10"),
        stdout=out,
    )

    assert "VDA 5050 vehicles R2 over MQTT" in out.getvalue()
    r1, r2 = Robot.objects.get(code="R1"), Robot.objects.get(code="R2")
    assert (r1.protocol, r1.presence, r1.status) == ("heartbeat", "online", "charging")
    assert r2.protocol == "vda5050"
    assert r2.last_seen_at is not None  # heard through the bridge
    # It said goodbye (OFFLINE) when the command stopped, which the bridge applies soon after.
    servers.poll(lambda: Robot.objects.get(code="R2").presence == "offline", what="R2 offline")
    assert (r2.status, r2.waypoint.code) == ("charging", "1F-DOCK-1")
