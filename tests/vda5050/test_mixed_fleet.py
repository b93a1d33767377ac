"""A mixed fleet, end to end: two heartbeat robots over real HTTP heartbeats and two VDA 5050
vehicles over MQTT share one elevator, one door and one corridor.

The production stack runs as subprocesses on the test database (bench/stack.py: gunicorn,
daphne, a Celery worker and Celery beat with every sweep), and so does the VDA 5050 bridge
(`manage.py vda5050_bridge`, as the Procfile runs it), against the real Mosquitto. The heartbeat
robots are robotsim's (a network losing 5 % of requests and of responses), the vehicles
robotsim's VDA 5050 ones. A spy on the broker records every order the bridge publishes.

What must hold: every delivery completes; every task moves through each status once; no two
robots ever held a capacity-1 resource at once; and a vehicle's order releases the nodes beyond
an elevator, door or corridor only by an update published after that robot's lease was granted.
"""

import subprocess
import sys
from datetime import UTC, datetime, timedelta

import pytest

from bench.stack import REPO, Stack
from resources.models import Lease
from robots.models import Alert, Resource, Robot
from robotsim.fleet import Fleet, FleetConfig, RobotSpec
from robotsim.network import NetworkModel
from robotsim.simulator import Behaviour
from robotsim.traffic import HttpTaskApi
from scheduling.models import Task, TaskTransition
from tests import factories, servers
from tests.vda5050.conftest import BUILDING_SPEEDUP, Spy, vda_robot_create, vehicle_start
from vda5050.validation import validator

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]

DELIVERIES = [
    (["1F-PHARM"], ["2F-LAB"]),  # elevator up, then the door
    (["3F-WARD"], ["1F-PHARM"]),  # elevator up, the corridor, down
    (["2F-LAB"], ["3F-WARD"]),
    (["1F-PHARM"], ["3F-WARD"]),
]
SPEEDUP = 25


@pytest.fixture
def stack(transactional_db, mosquitto):
    env = {
        "ALLOCATION_POLICY": "single",  # one task each: all four drive at once
        "BUILDING_SIM_SPEEDUP": str(BUILDING_SPEEDUP),
    }
    with Stack(database_url=servers.test_database_url(), web_workers=2, beat=True, env=env) as s:
        yield s


@pytest.fixture
def bridge_process(stack, interface):
    env = {**stack.env, "CELERY_QUEUE": stack.queue, "DATABASE_CONN_MAX_AGE": "0"}
    log = (stack.logs / "vda5050.log").open("wb")
    process = subprocess.Popen(
        [sys.executable, "manage.py", "vda5050_bridge", "--interface", interface],
        cwd=REPO,
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    yield process
    process.terminate()
    process.wait(timeout=10)
    print((stack.logs / "vda5050.log").read_text()[-3000:])


@pytest.fixture
def heartbeat_robots(site, stack):
    specs = []
    for code, dock in (("R1", "1F-DOCK-1"), ("R2", "1F-DOCK-2")):
        robot = factories.robot_create(site, code, dock=site.waypoints.get(code=dock))
        specs.append(RobotSpec(code=robot.code, token=robot.token, dock=dock))
    config = FleetConfig(
        server_url=stack.http_url,
        ws_url=stack.ws_url,
        site=factories.TINY_SITE,
        robots=tuple(specs),
        speedup=SPEEDUP,
        network=NetworkModel(request_loss=0.05, response_loss=0.05),
        behaviour=Behaviour(staff_delay=(3.0, 10.0)),
        seed=11,
    )
    fleet = Fleet(config)
    fleet.start()
    yield fleet
    fleet.stop()


@pytest.fixture
def vehicles(site, bridge_process, interface):
    robots = [
        vda_robot_create(site, "V1", "SN-1"),
        vda_robot_create(site, "V2", "SN-2", "1F-DOCK-2"),
    ]
    started = [
        vehicle_start(robot, interface, speedup=SPEEDUP, staff_delay=(3.0, 10.0))
        for robot in robots
    ]
    yield started
    for vehicle in started:
        vehicle.stop()


def test_a_mixed_fleet_shares_the_elevator_and_completes_every_delivery(
    site, stack, interface, heartbeat_robots, vehicles, staff
):
    with Spy(interface) as spy:
        servers.poll(
            lambda: Robot.objects.filter(presence="online").count() == 4,
            timeout=30,
            what="all four robots online",
        )
        api = HttpTaskApi(stack.http_url, staff.api_token_plain)
        codes = []
        for pickups, dropoffs in DELIVERIES:
            body = {"sender": "Ward", "receiver": "Lab", "contents": "Samples"}
            status, reply = api.post({**body, "pickups": pickups, "dropoffs": dropoffs})
            assert status == 201, reply
            codes.append(reply["code"])
        tasks = [int(code[2:]) for code in codes]
        servers.poll(
            lambda: (
                set(Task.objects.filter(pk__in=tasks).values_list("status", flat=True))
                == {"completed"}
            ),
            timeout=240,
            interval=0.5,
            what="every delivery completed",
        )
        servers.poll(
            lambda: heartbeat_robots.all_idle_at_dock() and all(v.idle_at_dock for v in vehicles),
            timeout=120,
            interval=0.5,
            what="every robot home",
        )
        # The vehicles' counterpart of "nothing left to tell the server": the bridge has applied
        # a state of each at home, and with it every event before.
        servers.poll(
            lambda: all(
                (r.status, r.waypoint_id) == ("charging", r.dock_id)
                for r in Robot.objects.filter(protocol="vda5050")
            ),
            timeout=60,
            interval=0.5,
            what="the server seeing the vehicles home",
        )
    assert heartbeat_robots.errors == []
    carried = set(Task.objects.filter(pk__in=tasks).values_list("robot__code", flat=True))
    assert {"V1", "V2"} <= carried, carried  # the vehicles did carry deliveries
    _assert_each_status_once(tasks)
    _assert_capacity_respected()
    _assert_horizon_released_after_grants(spy)


def _assert_each_status_once(tasks):
    for pk in tasks:
        moves = TaskTransition.objects.filter(task_id=pk).exclude(old="").values_list("old", "new")
        changes = [new for old, new in moves if old != new]
        for status in ("acknowledged", "picked_up", "delivered", "completed"):
            assert changes.count(status) == 1, (pk, list(moves))


def _assert_capacity_respected():
    rides = Lease.objects.filter(resource__code="ELEV", entered_at__isnull=False)
    riders = {lease.robot.code for lease in rides}
    assert {"V1", "V2"} <= riders, riders  # shared by both kinds
    assert riders & {"R1", "R2"}, riders
    live = list(Lease.objects.live().values_list("robot__code", "resource__code", "state"))
    assert not live, live
    assert not Alert.objects.filter(kind="entered_without_grant").exists()
    for resource in Resource.objects.filter(capacity=1):
        held = sorted(
            (lease.granted_at, lease.ended_at, lease.robot.code)
            for lease in Lease.objects.filter(resource=resource, granted_at__isnull=False)
        )
        for (_, ended, robot), (started, _, other) in zip(held, held[1:], strict=False):
            assert ended <= started, f"{robot} and {other} both held {resource.code}"


def _assert_horizon_released_after_grants(spy):
    orders = spy.of("order")
    assert orders
    for _, body in orders + spy.of("instantActions"):
        topic = "order" if "nodes" in body else "instantActions"
        assert not list(validator(topic).iter_errors(body)), body
    updates = 0
    for at, order in orders:
        robot = Robot.objects.get(serial_number=order["serialNumber"])
        guarded = [e for e in order["edges"] if e.get("edgeDescription") and e["released"]]
        if order["orderUpdateId"] == 0:
            assert not guarded, order  # a new order stops before every resource
            continue
        updates += 1
        received = datetime.fromtimestamp(at, UTC)
        for edge in guarded:
            granted = Lease.objects.filter(
                robot=robot,
                resource__code=edge["edgeDescription"],
                granted_at__lte=received,
                granted_at__gte=received - timedelta(minutes=2),
            )
            assert granted.exists(), (order["orderId"], edge)
    assert updates >= 4  # each vehicle rode the elevator at least twice
