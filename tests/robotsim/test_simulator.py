"""Simulated robots against the server in this process, on a virtual clock (no sockets).

Each step is one simulated second: robots move, heartbeat through the full HTTP stack (the
test client), and the sweeps Celery beat would run are called directly; allocation runs eagerly
on commit (conftest).
"""

import random
from dataclasses import replace

import pytest

from bench.inprocess import SERVER_URL, InProcessTaskApi, InProcessTransport
from boards.models import RobotEvent
from resources.leases import lease_sweep
from resources.models import Lease
from robots.models import Alert, Robot, SiteMembership
from robots.router import site_map_from_file
from robots.services import membership_badge_set
from robotsim.client import RobotClient
from robotsim.simulator import Behaviour, ManualClock, RobotLoop, SimRobot
from scheduling.models import CustodyEntry, Task
from scheduling.services import ack_timeout_sweep, due_sweep
from tests import factories

pytestmark = pytest.mark.django_db(transaction=True)

BEHAVIOUR = Behaviour(staff_delay=(5.0, 10.0))


class World:
    def __init__(self, site, data=factories.TINY_SITE):
        self.clock = ManualClock()
        self.site_map = site_map_from_file(data)
        self.loops: list[RobotLoop] = []
        self.site = site

    def robot(self, code: str, dock: str, *, behaviour=BEHAVIOUR, **secure) -> SimRobot:
        """secure: compartments (also the server's row) and pins, as SimRobot takes them."""
        waypoint = self.site.waypoints.get(code=dock)
        compartments = secure.get("compartments", [])
        row = factories.robot_create(self.site, code, dock=waypoint, compartments=compartments)
        client = RobotClient(
            server_url=SERVER_URL, robot=code, token=row.token, transport=InProcessTransport()
        )
        robot = SimRobot(
            client=client,
            site_map=self.site_map,
            dock=dock,
            clock=self.clock,
            rng=random.Random(code),
            behaviour=behaviour,
            **secure,
        )
        self.loops.append(RobotLoop(robot))
        return robot

    def run_until(self, done, *, limit: int = 3000) -> int:
        for _ in range(limit):
            now = self.clock.now() + 1
            self.clock.set(now)
            for loop in self.loops:
                loop.step(now)
            due_sweep()
            ack_timeout_sweep()
            lease_sweep()
            if done():
                return int(now)
        raise AssertionError(f"not done within {limit} simulated seconds")


@pytest.fixture
def world(site):
    return World(site)


@pytest.fixture
def api(staff):
    return InProcessTaskApi(staff.api_token_plain)


def order(api, pickups, dropoffs) -> str:
    body = {"sender": "a", "receiver": "b", "contents": "Samples"}
    status, reply = api.post({**body, "pickups": pickups, "dropoffs": dropoffs})
    assert status == 201, reply
    return reply["code"]


def completed(*codes):
    return lambda: Task.objects.filter(status="completed").count() == len(codes)


def test_it_carries_a_delivery_across_floors_through_every_kind_of_resource(world, api):
    robot = world.robot("R1", "1F-DOCK-1")
    world.run_until(lambda: robot.client.seq > 1)
    code = order(api, ["3F-WARD"], ["2F-LAB"])

    world.run_until(completed(code))
    world.run_until(lambda: robot.idle_at_dock and robot.client.unsent == 0)

    kinds = [(e["type"], e.get("resource") or e.get("task")) for e in robot.log if "type" in e]
    assert kinds == [
        ("resource_entered", "ELEV"),
        ("resource_released", "ELEV"),
        ("resource_entered", "CORR-3F"),
        ("resource_released", "CORR-3F"),
        ("arrived", code),
        ("loaded", code),
        ("resource_entered", "CORR-3F"),
        ("resource_released", "CORR-3F"),
        ("resource_entered", "ELEV"),
        ("resource_released", "ELEV"),
        ("resource_entered", "DOOR-2F"),
        ("resource_released", "DOOR-2F"),
        ("arrived", code),
        ("unloaded", code),
        ("task_completed", code),
        ("resource_entered", "DOOR-2F"),
        ("resource_released", "DOOR-2F"),
        ("resource_entered", "ELEV"),
        ("resource_released", "ELEV"),
    ]
    sent = {e["id"] for e in robot.log if "type" in e}
    assert set(RobotEvent.objects.values_list("event_id", flat=True)) == sent
    assert not Lease.objects.live().exists()
    assert robot.stats.rides == 3
    assert robot.battery < 1.0


def test_it_takes_a_second_task_on_its_way_and_finishes_both(world, api):
    robot = world.robot("R1", "1F-DOCK-1")
    world.run_until(lambda: robot.client.seq > 1)
    first = order(api, ["1F-PHARM"], ["3F-WARD"])
    world.run_until(lambda: robot.stats.loaded == 1)
    second = order(api, ["2F-LAB"], ["3F-WARD"])

    world.run_until(completed(first, second))

    assert Task.objects.get(pk=int(second[2:])).robot.code == "R1"
    assert robot.stats.completed == 2


def test_two_robots_share_the_elevator_one_at_a_time(world, api, settings):
    settings.ALLOCATION_POLICY = "single"  # one task each
    world.robot("R1", "1F-DOCK-1")
    world.robot("R2", "1F-DOCK-2")
    world.run_until(lambda: all(loop.client.seq > 1 for loop in world.loops))
    codes = [order(api, ["3F-WARD"], ["1F-PHARM"]), order(api, ["2F-LAB"], ["1F-PHARM"])]

    world.run_until(completed(*codes))

    rides = list(Lease.objects.filter(resource__code="ELEV").order_by("granted_at"))
    assert {lease.robot.code for lease in rides} == {"R1", "R2"}
    for earlier, later in zip(rides, rides[1:], strict=False):
        assert earlier.ended_at <= later.granted_at


def test_it_pauses_and_resumes_on_the_servers_word(world, api):
    from boards.services import board_post
    from robots.models import Robot

    robot = world.robot("R1", "1F-DOCK-1")
    world.run_until(lambda: robot.client.seq > 1)
    row = Robot.objects.get(code="R1")
    board_post(robot=row, type="action", body={"action": "pause"})
    world.run_until(lambda: robot.status == "paused")
    code = order(api, ["1F-PHARM"], ["2F-LAB"])
    world.run_until(lambda: robot.stops, limit=10)

    with pytest.raises(AssertionError):
        world.run_until(lambda: robot.waypoint != "1F-DOCK-1", limit=60)

    board_post(robot=row, type="action", body={"action": "resume"})
    world.run_until(completed(code))


LOCKING = [{"code": "A", "lockable": True}, {"code": "B"}]


def secure_order(api, pickups, dropoffs) -> tuple[str, str]:
    body = {"sender": "Pharmacy", "receiver": "Ward 3", "contents": "Morphine", "secure": True}
    status, reply = api.post({**body, "pickups": pickups, "dropoffs": dropoffs})
    assert status == 201, reply
    return reply["code"], reply["pin"]


def test_its_recipient_opens_a_secure_delivery_with_the_pin_after_a_wrong_one(world, api):
    pins = {}
    mistyping = Behaviour(staff_delay=(5.0, 10.0), wrong_pin=1.0)  # wrong first, then right
    robot = world.robot("R1", "1F-DOCK-1", behaviour=mistyping, compartments=LOCKING, pins=pins.get)
    world.run_until(lambda: robot.client.seq > 1)
    code, pins_code = secure_order(api, ["1F-PHARM"], ["3F-WARD"])
    pins[code] = pins_code

    world.run_until(completed(code))

    loaded = next(e for e in robot.log if e.get("type") == "loaded")
    unloaded = next(e for e in robot.log if e.get("type") == "unloaded")
    assert (loaded["compartment"], unloaded["compartment"], unloaded["opened_with"]) == (
        "A",
        "A",
        "pin",
    )
    kinds = list(CustodyEntry.objects.values_list("kind", "compartment", "failed_attempts"))
    assert kinds == [("loaded", "A", 0), ("unloaded", "A", 1)]


def test_a_user_of_the_receiving_unit_opens_it_with_a_badge_checked_offline(world, api, nurse):
    membership = SiteMembership.objects.get(user=nurse, site=world.site)
    membership.unit = world.site.waypoints.get(code="3F-WARD")
    membership.save(update_fields=["unit"])
    membership_badge_set(membership=membership, badge="04:A2:19:C3:7F:5E:80")
    badges = {"3F-WARD": "04:A2:19:C3:7F:5E:80"}.get  # nobody knows the PIN: only the badge
    always = Behaviour(staff_delay=(5.0, 10.0), badge_share=1.0)
    robot = world.robot("R1", "1F-DOCK-1", behaviour=always, compartments=LOCKING, badges=badges)
    world.run_until(lambda: robot.client.seq > 1)
    code, _pin = secure_order(api, ["1F-PHARM"], ["3F-WARD"])

    world.run_until(completed(code))

    unloaded = next(e for e in robot.log if e.get("type") == "unloaded")
    assert (unloaded["opened_with"], unloaded["opened_by"]) == ("badge", "kim")
    entry = CustodyEntry.objects.get(kind="unloaded")
    assert (entry.opened_with, entry.opened_by, entry.failed_attempts) == ("badge", "kim", 0)


def test_a_recipient_without_the_pin_gets_it_locked_and_operators_alerted(world, api):
    robot = world.robot("R1", "1F-DOCK-1", compartments=LOCKING)  # nobody knows the PIN
    world.run_until(lambda: robot.client.seq > 1)
    code, _pin = secure_order(api, ["1F-PHARM"], ["3F-WARD"])

    world.run_until(lambda: Alert.objects.filter(kind="compartment_locked").exists())

    locked = next(e for e in robot.log if e.get("type") == "compartment_locked")
    assert (locked["task"], locked["compartment"], locked["failed_attempts"]) == (code, "A", 3)
    assert Task.objects.get().status == "picked_up"  # its items stay locked on board
    assert not any(e.get("type") == "unloaded" for e in robot.log)


def test_a_robot_draining_as_its_site_says_is_sent_to_charge_and_back_to_work(world, api, site):
    # The robot's site file says 0.1 % per metre and 1 % per ride; the delivery (180 m, three
    # rides) takes it below the server's threshold (0.2), so the server sends it to charge.
    drains = {"battery_per_metre": 0.001, "battery_per_ride": 0.01}
    behaviour = Behaviour.for_site(drains, battery=0.35, staff_delay=(5.0, 10.0))
    robot = world.robot("R1", "1F-DOCK-1")
    robot.behaviour = replace(behaviour, charge_rate=1 / 600)  # full in 10 simulated minutes
    robot.battery = robot.lowest_battery = 0.35
    world.run_until(lambda: robot.client.seq > 1)
    code = order(api, ["3F-WARD"], ["2F-LAB"])

    world.run_until(lambda: Robot.objects.get(code="R1").sent_to_charge)

    assert Task.objects.with_code(code).get().status in ("delivered", "completed")
    assert robot.lowest_battery < 0.2
    world.run_until(lambda: not Robot.objects.get(code="R1").sent_to_charge, limit=3000)
    assert robot.battery >= 0.8
    assert robot.idle_at_dock


def test_a_fire_alarm_sends_it_to_a_refuge_and_after_the_all_clear_it_delivers_once(api, operator):
    from scheduling.services import emergency_end, emergency_start

    data = factories.tiny_site_with_refuge()
    site = factories.site_create(**data)
    world = World(site, data)
    robot = world.robot("R1", "1F-DOCK-1")
    world.run_until(lambda: robot.client.seq > 1)
    code = order(api, ["1F-PHARM"], ["2F-LAB"])
    world.run_until(lambda: robot.stops, limit=10)

    emergency_start(site=site, floors=["1F"], reason="drill", via="operator", by=operator)
    world.run_until(lambda: robot.waypoint == "1F-REFUGE", limit=120)
    with pytest.raises(AssertionError):  # it waits there, its delivery with it
        world.run_until(lambda: robot.waypoint != "1F-REFUGE", limit=120)
    assert Task.objects.get().status != "completed"

    emergency_end(site=site, via="operator", by=operator)
    world.run_until(completed(code))
    task = Task.objects.get()
    assert task.code == code
    notes = list(task.history.values_list("note", flat=True))
    assert any("waits at refuge point 1F-REFUGE" in note for note in notes)


def test_told_in_the_cabin_to_get_out_it_leaves_at_the_next_floor_and_waits(
    api, operator, settings
):
    from scheduling.services import emergency_end, emergency_start

    # Lifts the server does not drive: the robot gets out at the car's next floor, 2F, where
    # a refuge point waits for it. Its cabin has network, so it hears the message on the way.
    settings.BUILDING_ADAPTER = "none"
    data = factories.tiny_site_with_refuge()
    second = data["floors"][1]
    second["waypoints"].append({"code": "2F-REFUGE", "x": 10, "y": 0, "kind": "refuge"})
    second["edges"].append(["2F-ELEV-WAIT", "2F-REFUGE"])
    site = factories.site_create(**data)
    world = World(site, data)
    robot = world.robot("R1", "1F-DOCK-1", behaviour=replace(BEHAVIOUR, cabin_network=True))
    world.run_until(lambda: robot.client.seq > 1)
    code = order(api, ["1F-PHARM"], ["3F-WARD"])
    world.run_until(lambda: robot.riding, limit=600)

    emergency_start(site=site, floors=["2F"], reason="drill", via="operator", by=operator)
    world.run_until(lambda: robot.waypoint == "2F-ELEV-WAIT", limit=60)
    world.run_until(lambda: robot.waypoint == "2F-REFUGE", limit=60)
    assert robot.stats.rides == 1
    leases = Lease.objects.filter(robot__code="R1", resource__code="ELEV").order_by("pk")
    assert leases[0].state == "released"  # the ride, ended at 2F
    assert not leases.filter(state__in=["queued", "granted", "entered"]).exists()
    with pytest.raises(AssertionError):  # it waits there, its delivery on board
        world.run_until(lambda: robot.waypoint != "2F-REFUGE", limit=60)
    assert robot.on_board

    emergency_end(site=site, via="operator", by=operator)
    world.run_until(completed(code))
    assert Task.objects.get().code == code
    assert robot.stats.rides == 2
