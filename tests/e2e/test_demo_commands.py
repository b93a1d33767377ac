"""The one-command demo's two management commands: demo_setup and simulate_fleet."""

import json
import stat
from io import StringIO

import pytest
from django.contrib.auth import get_user_model
from django.core.management import CommandError, call_command

from hospital_delivery.models import ApiToken
from robots.models import Robot
from robots.services import robot_authenticate
from tests import factories


@pytest.fixture
def site_file(tmp_path):
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(factories.TINY_SITE))
    return path


@pytest.fixture
def demo(tmp_path, site_file):
    def run(*extra):
        out = StringIO()
        call_command(
            "demo_setup",
            *("--site-file", str(site_file), "--logins", str(tmp_path / "logins.json")),
            *("--fleet-file", str(tmp_path / "fleet.json"), "--server-url", "http://server:8000"),
            *extra,
            stdout=out,
        )
        return out.getvalue()

    return run


def private(path) -> bool:
    return stat.S_IMODE(path.stat().st_mode) == 0o600


@pytest.mark.django_db
def test_demo_setup_creates_the_demo_users_once_and_prints_their_logins(demo, tmp_path, site):
    first = demo("--only", "users")
    second = demo("--only", "users")

    logins = json.loads((tmp_path / "logins.json").read_text())
    assert private(tmp_path / "logins.json")
    assert set(logins) == {"admin", "operator", "nurse"}
    assert first == second
    assert all(password in first for password in logins.values())
    users = {user.username: user for user in get_user_model().objects.all()}
    assert users["admin"].is_superuser
    assert not users["operator"].is_staff  # an operator has no admin and no map editor
    assert users["operator"].groups.filter(name="operator").exists()
    assert not users["nurse"].is_staff
    assert users["nurse"].groups.filter(name="nurse").exists()
    assert all(users[name].check_password(password) for name, password in logins.items())


@pytest.mark.django_db
def test_demo_setup_writes_the_fleets_credentials_fresh_on_every_run(demo, tmp_path, site):
    factories.robot_create(site, "R1")
    demo("--only", "fleet")
    before = json.loads((tmp_path / "fleet.json").read_text())
    demo("--only", "fleet")

    fleet = json.loads((tmp_path / "fleet.json").read_text())
    assert private(tmp_path / "fleet.json")
    assert fleet["server_url"] == "http://server:8000"
    assert [(r["code"], r["dock"]) for r in fleet["robots"]] == [("R1", "1F-DOCK-1")]
    assert robot_authenticate(token=fleet["robots"][0]["token"]).code == "R1"
    assert robot_authenticate(token=before["robots"][0]["token"]) is None
    traffic = ApiToken.objects.for_token(fleet["traffic_token"]).get().user
    assert traffic.is_staff
    assert not traffic.has_usable_password()


@pytest.mark.django_db
def test_demo_setup_needs_the_site_loaded(demo):
    with pytest.raises(CommandError, match="not loaded"):
        demo("--only", "fleet")


@pytest.fixture
def fleet_file(tmp_path, site_file, live_server, site):
    robot = factories.robot_create(site, "R1")
    path = tmp_path / "fleet.json"
    path.write_text(
        json.dumps(
            {
                "server_url": live_server.url,
                "ws_url": None,
                "site_file": str(site_file),
                "robots": [{"code": "R1", "token": robot.token, "dock": "1F-DOCK-1"}],
            }
        )
    )
    return path


def test_simulate_fleet_runs_robots_against_the_server_until_stopped(fleet_file):
    out = StringIO()

    call_command(
        "simulate_fleet",
        "--fleet",
        str(fleet_file),
        "--duration",
        "2",
        "--speedup",
        "10",
        stdout=out,
    )

    assert "Simulated fleet R1 on tiny" in out.getvalue()
    assert "fleet stopped" in out.getvalue()
    robot = Robot.objects.get(code="R1")
    assert robot.presence == "online"
    assert robot.seq >= 1
    assert (robot.status, robot.waypoint.code) == ("charging", "1F-DOCK-1")


def test_simulate_fleet_refuses_a_dead_zone_where_robots_wait(fleet_file):
    with pytest.raises(CommandError, match="robots wait there"):
        call_command("simulate_fleet", "--fleet", str(fleet_file), "--dead-zone", "1F-PHARM")


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--speedup", "0", "--speedup: must be above 0"),
        ("--traffic", "-1", "--traffic: must be 0 or more"),
        ("--staff-delay", "40,10", "--staff-delay: want 0 <= MIN <= MAX"),
        ("--request-loss", "1.5", "request_loss"),
    ],
)
def test_simulate_fleet_names_the_option_it_refuses(fleet_file, option, value, message):
    with pytest.raises(CommandError, match=message):
        call_command("simulate_fleet", "--fleet", str(fleet_file), option, value)
