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

Monitoring and other systems watch the same run: /metrics, scraped before the deliveries are
ordered and after they are done (prometheus_client's multiprocess mode across the gunicorn
workers and the Celery worker, as run.sh runs it), shows the figures move; two webhook
receivers, one of which fails its first requests, each hear of every status change of every
delivery, signed, and the failing one gets what it refused on a retry.
"""

import pytest
import requests

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
from tests.reports.metrics import value
from tests.webhooks.conftest import LOOPBACK, subscribe
from tests.webhooks.receiver import HookReceiver

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
METRICS_TOKEN = "e2e-metrics-token"
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
def stack(transactional_db, tmp_path):
    url = servers.test_database_url()
    env = {
        **SINGLE_TASK,
        "METRICS_TOKEN": METRICS_TOKEN,
        "PROMETHEUS_MULTIPROC_DIR": str(tmp_path),
        "WEBHOOK_SWEEP_SECONDS": "1",
        "WEBHOOK_ALLOWED_NETWORKS": ",".join(LOOPBACK),  # the receivers listen on 127.0.0.1
    }
    with Stack(database_url=url, web_workers=2, beat=True, env=env) as stack:
        yield stack


@pytest.fixture
def receivers(site, settings):
    """Another system that answers at once, and one that fails its first five requests."""
    settings.WEBHOOK_ALLOWED_NETWORKS = LOOPBACK
    with HookReceiver() as steady, HookReceiver(fail_first=5) as flaky:
        steady.subscription = subscribe(site, steady.url, name="Laboratory system")
        flaky.subscription = subscribe(site, flaky.url, name="Pharmacy system")
        yield steady, flaky


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


def test_every_delivery_completes_exactly_once_without_sharing_the_elevator(
    receivers, fleet, stack, staff
):
    servers.poll(
        lambda: all(loop.client.seq > 0 and loop.robot.client.unsent == 0 for loop in fleet.loops),
        timeout=20,
        what="every robot heard from",
    )
    before = scrape(stack)

    codes = order_all(stack, staff)

    # Deadlines for a shared, loaded machine (several test suites at once); done sooner alone.
    servers.poll(all_completed(codes), timeout=180, interval=0.2, what="every delivery completed")
    servers.poll(fleet.all_idle_at_dock, timeout=90, interval=0.2, what="every robot home")
    after = scrape(stack)  # while the robots still heartbeat
    fleet.stop()
    _assert_metrics_moved(before, after, codes)
    _assert_webhooks_heard_every_change(receivers, codes)

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


def scrape(stack) -> str:
    headers = {"Authorization": f"Bearer {METRICS_TOKEN}"}
    response = requests.get(f"{stack.http_url}/metrics", headers=headers, timeout=30)
    assert response.status_code == 200, response.text
    return response.text


def _assert_metrics_moved(before: str, after: str, codes):
    site = factories.TINY_SITE["site"]
    heartbeats = value(after, "hd_heartbeats_total", code="200")
    assert heartbeats > value(before, "hd_heartbeats_total", code="200") > 0
    assert value(after, "hd_heartbeat_seconds_count") > value(before, "hd_heartbeat_seconds_count")
    assert value(before, "hd_tasks", site=site, status="completed") == 0
    assert value(after, "hd_tasks", site=site, status="completed") == len(codes)
    assert value(after, "hd_allocation_seconds_count") >= len(codes)  # web and Celery workers
    assert value(after, "hd_lease_wait_seconds_count", kind="elevator") > 0
    assert value(after, "hd_robots", site=site) == 3
    assert value(after, "hd_robots", site=site, presence="online") > 0  # lossy: some may lag
    assert value(before, "hd_robots", site=site, status="unknown") == 0  # all reported
    assert value(after, "hd_sweep_last_success_timestamp_seconds") > 0
    assert value(after, "hd_redis_up") == 1


def _assert_webhooks_heard_every_change(receivers, codes):
    changes = {
        f"task-transition-{pk}": (code, new)
        for code in codes
        for pk, old, new in TaskTransition.objects.filter(task_id=int(code[2:])).values_list(
            "pk", "old", "new"
        )
        if old != new
    }
    steady, flaky = receivers

    def everything_heard():
        return all({got.event_id for got in r.accepted()} >= set(changes) for r in receivers)

    servers.poll(everything_heard, timeout=60, interval=0.2, what="every change delivered")
    for receiver in receivers:
        accepted = receiver.accepted()
        assert {got.event_id for got in accepted} == set(changes)
        assert all(got.signed_with(receiver.subscription.secret) for got in receiver.received)
        told = {
            got.event_id: (got.payload["task"]["code"], got.payload["task"]["status"])
            for got in accepted
        }
        assert told == changes
    assert len(flaky.refused()) == 5
    assert {got.event_id for got in flaky.refused()} <= {got.event_id for got in flaky.accepted()}
