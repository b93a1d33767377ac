"""A small simulated fleet, end to end, against the production stack with a lossy network.

gunicorn (2 sync workers), daphne (the robots' push channel), a Celery worker and Celery beat
run as subprocesses on the test database (bench/stack.py), exactly as the Procfile runs them;
beat sends the sweeps (presence, leases, due tasks, ack timeouts) every second, as in
production. Three simulated robots (robotsim.fleet), one delivery each at a time (single-task
allocation, so that they all drive at once and queue for the elevator), drive the test site
at 25x, each through a network that loses 10 % of requests and 10 % of responses, duplicates
5 % (sent again up to 2 s later), has a dead zone at 1F-HALL and no connection in the elevator
cabin. Deliveries are ordered through the public task API.

The sweeps come from a real beat process rather than from the test calling the services: the
robots run in threads against subprocess servers in real time, so there is no step to call
them at, and the production schedule is what has to cope with the losses.

What must hold: every delivery completes; every event a robot sent is recorded exactly once
and applied once; no two robots ever held the elevator (or any capacity-1 resource) at once.
"""

import pytest

from bench.stack import Stack
from boards.models import RobotEvent
from resources.models import Lease
from robots.models import Alert, Resource
from robotsim.fleet import Fleet, FleetConfig, RobotSpec
from robotsim.network import NetworkModel
from robotsim.simulator import Behaviour
from robotsim.traffic import HttpTaskApi
from scheduling.models import Task, TaskStop, TaskTransition
from tests import factories, servers

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]

DELIVERIES = [
    (["3F-WARD"], ["2F-LAB"]),
    (["1F-PHARM"], ["3F-WARD"]),
    (["1F-PHARM"], ["2F-LAB", "3F-WARD"]),  # one-to-many
    (["2F-LAB"], ["1F-PHARM"]),
    (["3F-WARD"], ["1F-PHARM"]),
]
# Online multi-task allocation would give all five deliveries to the first robot (it lengthens
# that robot's route least; robotsim's in-process tests cover it). One task per robot at a
# time makes all three robots drive at once and queue for the elevator, door and corridor.
SINGLE_TASK = {"ALLOCATION_POLICY": "single"}
NETWORK = NetworkModel(
    request_loss=0.10,
    response_loss=0.10,
    duplicate=0.05,
    delay=(0.0, 0.005),
    dead_zones=frozenset({"1F-HALL"}),
)


@pytest.fixture
def robots(site):
    docks = ["1F-DOCK-1", "1F-DOCK-2", "1F-DOCK-1"]
    made = []
    for n, dock in enumerate(docks, start=1):
        robot = factories.robot_create(site, f"R{n}", dock=site.waypoints.get(code=dock))
        made.append(RobotSpec(code=robot.code, token=robot.token, dock=dock))
    return made


@pytest.fixture
def stack(transactional_db):
    url = servers.test_database_url()
    with Stack(database_url=url, web_workers=2, beat=True, env=SINGLE_TASK) as stack:
        yield stack


@pytest.fixture
def fleet(stack, robots):
    config = FleetConfig(
        server_url=stack.http_url,
        ws_url=stack.ws_url,
        site=factories.TINY_SITE,
        robots=tuple(robots),
        speedup=25,
        network=NETWORK,
        behaviour=Behaviour(staff_delay=(3.0, 10.0)),
        seed=7,
    )
    fleet = Fleet(config)
    fleet.start()
    yield fleet
    fleet.stop()


def order_all(stack, staff) -> list[str]:
    api = HttpTaskApi(stack.http_url, staff.api_token_plain)
    codes = []
    for pickups, dropoffs in DELIVERIES:
        body = {"sender": "Ward 3", "receiver": "Lab", "contents": "Samples"}
        status, reply = api.post({**body, "pickups": pickups, "dropoffs": dropoffs})
        assert status == 201, reply
        codes.append(reply["code"])
    return codes


def all_completed(codes):
    def check():
        statuses = dict(Task.objects.values_list("pk", "status"))
        return all(statuses[int(code[2:])] == "completed" for code in codes)

    return check


def test_every_delivery_completes_exactly_once_without_sharing_the_elevator(fleet, stack, staff):
    servers.poll(
        lambda: all(loop.client.seq > 0 and loop.robot.client.unsent == 0 for loop in fleet.loops),
        timeout=20,
        what="every robot heard from",
    )

    codes = order_all(stack, staff)

    # Deadlines for a shared, loaded machine (several test suites at once); done sooner alone.
    servers.poll(all_completed(codes), timeout=180, interval=0.2, what="every delivery completed")
    servers.poll(fleet.all_idle_at_dock, timeout=90, interval=0.2, what="every robot home")
    fleet.stop()

    assert fleet.errors == []
    assert all(loop.refused == 0 for loop in fleet.loops)
    network = fleet.network_stats()
    assert network.requests_lost, network
    assert network.responses_lost, network
    assert network.offline, network  # the elevator cabin and the dead zone
    _assert_events_recorded_once(fleet)
    _assert_events_applied_once(codes)
    _assert_capacity_respected()


def _assert_events_recorded_once(fleet):
    for robot in fleet.robots:
        sent = [entry["id"] for entry in robot.log if "type" in entry]
        recorded = list(
            RobotEvent.objects.filter(robot__code=robot.code).values_list("event_id", flat=True)
        )
        assert sorted(recorded) == sorted(sent), robot.code


def _assert_events_applied_once(codes):
    for code in codes:
        task = Task.objects.get(pk=int(code[2:]))
        moves = list(
            TaskTransition.objects.filter(task=task).exclude(old="").values_list("old", "new")
        )
        changes = [new for old, new in moves if old != new]
        for status in ("acknowledged", "picked_up", "delivered", "completed"):
            assert changes.count(status) == 1, (code, moves)
        stops = TaskStop.objects.filter(task=task)
        assert all(stop.done_at and stop.done_by_id for stop in stops), code
    done_by = list(TaskStop.objects.values_list("done_by", flat=True))
    assert len(done_by) == len(set(done_by))


def _assert_capacity_respected():
    rides = Lease.objects.filter(resource__code="ELEV", entered_at__isnull=False)
    assert len({lease.robot_id for lease in rides}) >= 2  # the elevator was shared
    assert not Lease.objects.live().exists()
    assert not Alert.objects.filter(kind="entered_without_grant").exists()
    for resource in Resource.objects.filter(capacity=1):
        held = sorted(
            (lease.granted_at, lease.ended_at, lease.robot.code)
            for lease in Lease.objects.filter(resource=resource, granted_at__isnull=False)
        )
        for (_, ended, robot), (started, _, other) in zip(held, held[1:], strict=False):
            assert ended <= started, f"{robot} and {other} both held {resource.code}"
