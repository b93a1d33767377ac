"""VDA 5050 tests run against the real Mosquitto on 127.0.0.1:1883 (./scripts/test.sh starts it,
scripts/lib.sh ensure_mosquitto), each on an interface name (the topics' first level) of its
own, so runs side by side on the shared broker never see each other's messages."""

import json
import socket
import threading
import time
import uuid

import paho.mqtt.client as mqtt
import pytest
from django.db import connections
from django.test import override_settings
from django.utils import timezone

from building.services import sim_sweep
from robots.mapcache import router_for, site_map
from robots.models import Robot, Waypoint
from robotsim.vda5050 import VdaVehicle
from scheduling.services.requests import task_request
from tests import factories
from vda5050.bridge import Bridge
from vda5050.link import Link

BROKER = ("127.0.0.1", 1883)
MANUFACTURER = "Acme"
# The simulated lifts and doors as fast as the simulated vehicles drive (vehicle_start's
# speedup): a ride takes a second, not the real lift's ten.
BUILDING_SPEEDUP = 10


@pytest.fixture(scope="session")
def mosquitto():
    try:
        socket.create_connection(BROKER, timeout=2).close()
    except OSError:
        pytest.fail("Mosquitto is not answering on 127.0.0.1:1883 (./scripts/test.sh starts it)")
    return BROKER


@pytest.fixture
def interface(mosquitto):
    return f"hdtest{uuid.uuid4().hex[:10]}"


class SimBuilding:
    """The building's simulated lifts and doors, stepped as Celery beat's building sweep does
    (building.services.sim_sweep), on a thread of its own: the bridge lets a vehicle into a
    lift only once the car reports its floor."""

    def __init__(self):
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.settings = override_settings(BUILDING_SIM_SPEEDUP=BUILDING_SPEEDUP)

    def _run(self):
        try:
            while not self.stopped.wait(0.1):
                sim_sweep(now=timezone.now())
        finally:
            connections.close_all()

    def __enter__(self):
        self.settings.enable()
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stopped.set()
        self.thread.join(timeout=10)
        self.settings.disable()


@pytest.fixture
def bridge(transactional_db, interface):
    bridge = Bridge(host=BROKER[0], port=BROKER[1], interface=interface)
    bridge.start()
    with SimBuilding():
        yield bridge
    bridge.stop()


def vda_robot_create(site, code: str, serial: str, dock: str = "1F-DOCK-1") -> Robot:
    return factories.robot_create(
        site,
        code,
        dock=site.waypoints.get(code=dock),
        protocol="vda5050",
        manufacturer=MANUFACTURER,
        serial_number=serial,
    )


@pytest.fixture
def vehicle(site):
    """A VDA 5050 vehicle of the site, driven in process through its Link (no MQTT)."""
    return vda_robot_create(site, "V1", "SN-1")


@pytest.fixture
def link(vehicle):
    return Link(
        robot_id=vehicle.pk,
        robot_code=vehicle.code,
        dock=vehicle.dock.code,
        site_map=site_map(vehicle.site),
        router=router_for(vehicle.site),
    )


def vehicle_start(robot: Robot, interface: str, **options) -> VdaVehicle:
    options.setdefault("speedup", 25)
    options.setdefault("staff_delay", (2.0, 6.0))
    options.setdefault("state_every", 0.2)
    vehicle = VdaVehicle(
        site_map=site_map(robot.site),
        manufacturer=robot.manufacturer,
        serial_number=robot.serial_number,
        dock=robot.dock.code,
        host=BROKER[0],
        port=BROKER[1],
        interface=interface,
        **options,
    )
    vehicle.start()
    return vehicle


def deliver(site, pickups, dropoffs):
    stations = {wp.code: wp for wp in Waypoint.objects.filter(site=site)}
    with override_settings(ALLOCATE_ON_REQUEST=True):
        return task_request(
            site=site,
            requester=None,
            sender="Pharmacy",
            receiver="Lab",
            contents="Samples",
            pickups=[stations[code] for code in pickups],
            dropoffs=[stations[code] for code in dropoffs],
        )


class Spy:
    """Records every message on the run's topics, with when it arrived."""

    def __init__(self, interface: str):
        self.messages: list[tuple[float, str, dict | bytes]] = []
        self.lock = threading.Lock()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2)
        self.client.on_message = self._on_message
        self.interface = interface
        self.subscribed = threading.Event()
        self.client.on_subscribe = lambda *args: self.subscribed.set()
        self.client.on_connect = lambda client, *args: client.subscribe(f"{interface}/#", qos=1)

    def __enter__(self):
        self.client.connect(*BROKER)
        self.client.loop_start()
        assert self.subscribed.wait(5)
        return self

    def __exit__(self, *exc):
        self.client.disconnect()
        self.client.loop_stop()

    def _on_message(self, client, userdata, message):
        try:
            body = json.loads(message.payload)
        except ValueError:
            body = message.payload
        with self.lock:
            self.messages.append((time.time(), message.topic, body))

    def of(self, topic: str) -> list[tuple[float, dict]]:
        with self.lock:
            return [(at, body) for at, t, body in self.messages if t.endswith(f"/{topic}")]


def publish(interface: str, serial: str, topic: str, payload: bytes | str) -> None:
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2)
    client.connect(*BROKER)
    client.loop_start()
    info = client.publish(f"{interface}/v2/{MANUFACTURER}/{serial}/{topic}", payload, qos=1)
    info.wait_for_publish(timeout=5)
    client.disconnect()
    client.loop_stop()
