"""A connected vehicle at VDA 5050 2.0's slowest state interval (a state every 30 s while
nothing happens: vda-5050-lib's default) is never made unreachable. Long, so run on demand:

    HD_QUIET_SOAK_SECONDS=600 ./scripts/test.sh tests/vda5050/test_quiet_soak.py

(the integrators' VDA 5050 page gives the last run's figures)."""

import os
import time

import pytest

from robots.models import PresenceChange
from robots.services import presence_sweep
from tests import servers
from tests.vda5050.conftest import BROKER, Spy
from tests.vda5050.test_third_party import LIB_OPTIONS, lib_robot, online
from tests.vda_5050_lib import LibVehicle, LibVehicles

SECONDS = float(os.environ.get("HD_QUIET_SOAK_SECONDS", "0"))

pytestmark = [
    pytest.mark.slow,
    pytest.mark.django_db(transaction=True),
    pytest.mark.skipif(not SECONDS, reason="on demand: HD_QUIET_SOAK_SECONDS"),
]


def test_it_never_flips_a_quiet_connected_vehicle(site, bridge, interface):
    assert "state_interval" not in LIB_OPTIONS  # the bridge assumes 2.0's 30 s
    robot = lib_robot(site, "V1", "SN-1", "1F-DOCK-1")
    with (
        Spy(interface) as spy,
        LibVehicles([LibVehicle(robot, 30)], broker=BROKER, interface=interface),
    ):
        servers.poll(lambda: online(robot), timeout=20, what="the vehicle online")
        started = time.monotonic()

        def soaked():
            presence_sweep()  # as Celery beat runs it
            return time.monotonic() - started >= SECONDS

        servers.poll(soaked, timeout=SECONDS + 60, interval=0.5, what="the soak's end")
        states = len(spy.of("state"))
    flips = PresenceChange.objects.filter(robot=robot).exclude(new="online").count()
    print(f"\nquiet vehicle: {SECONDS:.0f} s connected, {states} states, {flips} presence flips")
    assert flips == 0
