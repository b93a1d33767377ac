"""An order followed through FHIR while a simulated robot delivers it.

The hospital system orders and polls over real HTTP with fhirpy (the live server); the robot is
robotsim's, heartbeating through the full HTTP stack in this process on a virtual clock, with
the sweeps Celery beat would run called each simulated second (as tests/robotsim does).
"""

import random
from datetime import timedelta

import pytest
from django.utils import timezone

from bench.inprocess import SERVER_URL, InProcessTransport
from resources.leases import lease_sweep
from robots.router import site_map_from_file
from robotsim.client import RobotClient
from robotsim.simulator import Behaviour, ManualClock, RobotLoop, SimRobot
from scheduling.models import Task
from scheduling.services import ack_timeout_sweep, due_sweep
from tests import factories
from tests.fhir.conftest import ordered_task, secure_inputs

pytestmark = pytest.mark.django_db(transaction=True)

LOCKING = [{"code": "A", "lockable": True}, {"code": "B"}]
CAREFUL = Behaviour(staff_delay=(5.0, 10.0), wrong_pin=0.0)


class World:
    """One simulated robot on the tiny site, driven a simulated second at a time."""

    def __init__(self, site, pins: dict):
        self.clock, self.site, self.loops = ManualClock(), site, []
        self.site_map = site_map_from_file(factories.TINY_SITE)
        self.pins = pins

    def robot(self, code: str, dock: str) -> SimRobot:
        row = factories.robot_create(
            self.site, code, dock=self.site.waypoints.get(code=dock), compartments=LOCKING
        )
        client = RobotClient(
            server_url=SERVER_URL, robot=code, token=row.token, transport=InProcessTransport()
        )
        robot = SimRobot(
            client=client,
            site_map=self.site_map,
            dock=dock,
            clock=self.clock,
            rng=random.Random(code),
            behaviour=CAREFUL,
            compartments=LOCKING,
            pins=self.pins.get,
        )
        robot.row = row
        self.loops.append(RobotLoop(robot))
        return robot

    def run_until(self, done, *, every=None, limit: int = 3000) -> None:
        for second in range(1, limit + 1):
            now = self.clock.now() + 1
            self.clock.set(now)
            for loop in self.loops:
                loop.step(now)
            due_sweep()
            ack_timeout_sweep()
            lease_sweep()
            if every is not None and second % 5 == 0:
                every()
            if done():
                return
        raise AssertionError(f"not done within {limit} simulated seconds")


@pytest.fixture
def world(site):
    return World(site, pins={})


def test_it_follows_a_secure_order_to_completed_while_a_robot_delivers_it(fhir, world):
    robot = world.robot("R1", "1F-DOCK-1")
    world.run_until(lambda: robot.client.seq > 1)
    body = ordered_task(identifier="RX-5005")
    body["input"] += secure_inputs("Nurse Park")
    created = fhir.resource("Task", **body).save().serialize()
    outputs = {o["type"]["coding"][0]["code"]: o for o in created["output"]}
    pin = outputs["pin"]["valueString"]
    world.pins[created["id"]] = pin
    seen, since = [], {"at": created["meta"]["lastUpdated"]}

    def poll():  # as an ordering system polls: what changed since it last looked
        for task in fhir.resources("Task").search(_lastUpdated=f"gt{since['at']}").fetch_all():
            since["at"] = task["meta"]["lastUpdated"]
            step = (task["status"], task["businessStatus"]["coding"][0]["code"])
            if not seen or seen[-1] != step:
                seen.append(step)

    world.run_until(lambda: Task.objects.filter(status="completed").exists(), every=poll)
    poll()

    statuses = [status for n, (status, _) in enumerate(seen) if n == 0 or seen[n - 1][0] != status]
    assert [s for s in statuses if s != "requested"] == ["accepted", "in-progress", "completed"]
    assert ("in-progress", "at-dropoff") in seen  # waiting for the recipient's PIN
    done = fhir.reference("Task", created["id"]).to_resource().serialize()
    assert done["owner"]["reference"] == f"Device/robot-{robot.row.pk}"
    assert set(done["executionPeriod"]) == {"start", "end"}
    hand_offs = [o["type"]["coding"][0]["code"] for o in done["output"]]
    assert hand_offs == ["loaded", "handed-over"]
    assert "opened with the delivery's PIN" in done["output"][1]["valueAnnotation"]["text"]
    kinds = {i["type"]["coding"][0]["code"]: i for i in done["input"]}
    assert kinds["secure"]["valueBoolean"] is True
    assert kinds["recipient"]["valueString"] == "Nurse Park"
    assert done["meta"]["versionId"] == str(Task.objects.get().history.count())
    device = fhir.reference("Device", f"robot-{robot.row.pk}").to_resource()
    assert device["identifier"][0]["value"] == "R1"


def test_it_allocates_a_stat_order_with_a_deadline_ahead_of_routine_work(fhir, world, settings):
    settings.ALLOCATION_POLICY = "single"  # one task at a time: the robot must choose
    robot = world.robot("R1", "1F-DOCK-1")  # offline until it heartbeats: orders wait
    routine = [
        fhir.resource("Task", **ordered_task(identifier=f"RX-{n}")).save().id for n in (1, 2)
    ]
    deadline = (timezone.now() + timedelta(minutes=15)).replace(microsecond=0)
    stat_order = ordered_task(
        identifier="RX-STAT",
        priority="stat",
        pickup="2F-LAB",
        dropoff="3F-WARD",
        restriction={"period": {"end": deadline.isoformat()}},
    )
    stat = fhir.resource("Task", **stat_order).save()

    world.run_until(lambda: Task.objects.exclude(robot=None).exists())

    taken = fhir.resources("Task").search(owner=f"Device/robot-{robot.row.pk}").fetch_all()
    assert [task.id for task in taken] == [stat.id]
    assert taken[0]["status"] == "accepted"
    assert taken[0]["restriction"]["period"]["end"] == deadline.isoformat()
    assert Task.objects.get(pk=int(stat.id[2:])).due_at == deadline
    waiting = fhir.resources("Task").search(status="requested").fetch_all()
    assert sorted(task.id for task in waiting) == sorted(routine)
