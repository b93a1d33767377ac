"""A fire panel over MQTT (building/bridge.py, docs/building-devices.md) against the real
Mosquitto: its state starts the site's fire alarm on its floors and ends the one it started;
a bad state is counted and changes nothing."""

import pytest

from robots.models import Emergency, Site
from scheduling.services import emergency_end, emergency_start
from tests import factories
from tests.building.test_mqtt import publish_state
from tests.scheduling.conftest import robot_ready
from tests.scheduling.test_fire_alarm import actions

pytestmark = pytest.mark.django_db


@pytest.fixture
def panel(prefix, controller):
    topic = f"{prefix}/tiny/fire_panel"
    yield topic
    controller.publish(topic, b"", qos=1, retain=True).wait_for_publish(5)  # no leftovers


def panel_state(controller, bridge, panel, payload, expect: str) -> None:
    """As a fire panel's gateway publishes: retained, so the bridge reads it even while it
    is still subscribing."""
    publish_state(controller, bridge, panel, payload, expect, retain=True)


def in_force(site) -> Emergency | None:
    return Emergency.objects.active().filter(site=site).first()


def test_the_panel_starts_the_alarm_on_its_floors_and_ends_it(site, controller, bridge, panel):
    robot = robot_ready(factories.robot_create(site, "R1"))
    alarm = {"alarm": True, "floors": ["1F", "2F"], "reason": "detector zone 3"}

    panel_state(controller, bridge, panel, alarm, expect="applied")

    started = in_force(site)
    assert (started.floors, started.reason, started.started_via) == (
        ["1F", "2F"],
        "detector zone 3",
        "building",
    )
    assert actions(robot) == ["pause"]
    assert Site.objects.get(pk=site.pk).fire_alarm_since == started.started_at
    panel_state(controller, bridge, panel, alarm, expect="applied")  # repeated: nothing new
    assert Emergency.objects.count() == 1

    panel_state(controller, bridge, panel, {"alarm": False}, expect="applied")

    assert in_force(site) is None
    started.refresh_from_db()
    assert started.ended_via == "building"
    assert actions(robot) == ["resume"]


def test_the_panel_never_ends_an_alarm_an_operator_started(
    site,
    operator,
    controller,
    bridge,
    panel,
):
    emergency_start(site=site, floors=[], reason="drill", via="operator", by=operator)
    panel_state(controller, bridge, panel, {"alarm": False}, expect="applied")
    assert in_force(site) is not None
    emergency_end(site=site, via="operator", by=operator)


def test_bad_panel_states_are_counted_and_change_nothing(site, controller, bridge, panel):
    bad = [
        b"{not json",
        {"alarm": "yes"},
        {"floors": ["1F"]},
        {"alarm": True, "floors": "1F"},
        {"alarm": True, "floors": ["9F"]},  # no such floor at the site
        {"alarm": True, "reason": 3},
    ]
    for n, payload in enumerate(bad, start=1):
        panel_state(controller, bridge, panel, payload, expect="invalid")
        assert bridge.counts.invalid == n
    assert not Emergency.objects.exists()
    assert Site.objects.get(pk=site.pk).fire_alarm_since is None
