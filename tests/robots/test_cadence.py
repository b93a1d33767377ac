"""The heartbeat interval told to robots follows the load (robots/cadence.py): the robots not
offline against the operator's ceiling, and the queue for a web worker (core/busy.py); and
presence deadlines follow the interval each robot was told, so a robot that obeys is never
flipped. The controller is fed windows directly, or a model of a pool serving a fleet
(tests/robots/pool_model.py): no clock, no sleep."""

import math
import multiprocessing
import socket
import time
from datetime import timedelta

import pytest
from django.utils import timezone

from core.busy import WINDOW_SECONDS, BusyMeter, Tally, Window, busy
from robots import cadence
from robots.cadence import (
    AIM,
    PROBE,
    PROBE_QUIET,
    Controller,
    cadence_forget,
    heartbeat_backlog,
)
from robots.models import HeartbeatCadence, Robot
from robots.services import presence_sweep
from tests import factories
from tests.robots import pool_model


@pytest.fixture(autouse=True)
def fresh_count():
    cadence_forget()
    yield
    cadence_forget()


def robots_heartbeating(site, count):
    """`count` robots besides R1 that the server believes are heartbeating."""
    for n in range(count):
        robot = factories.robot_create(site, f"X{n + 1}")
        Robot.objects.filter(pk=robot.pk).update(presence="online")


def test_under_capacity_robots_are_told_the_sites_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 100
    robots_heartbeating(robot.site, 10)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 1.0


def test_over_capacity_every_robot_is_told_a_longer_interval_in_steps(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10  # aimed at 9/s: 21 robots need 2.33 s, told 2.5 s
    robots_heartbeating(robot.site, 20)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 2.5)


def test_the_interval_falls_back_when_robots_go_offline(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10
    robots_heartbeating(robot.site, 20)
    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 2.5)

    Robot.objects.exclude(pk=robot.pk).update(presence="offline")
    cadence_forget()  # the next count, as COUNT_SECONDS later

    assert robot_http.heartbeat(2)["heartbeat_interval"] == 1.0


def test_the_interval_is_capped(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1
    settings.HEARTBEAT_INTERVAL_MAX = 4
    robots_heartbeating(robot.site, 20)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 4.0)


def test_a_robot_that_obeys_a_longer_interval_is_not_flipped(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10
    robots_heartbeating(robot.site, 20)
    told = robot_http.heartbeat(1)["heartbeat_interval"]
    robot.refresh_from_db()
    seen = robot.last_seen_at

    assert robot.unreachable_at - seen == timedelta(seconds=3 * told)
    # Just before 3 told intervals (past the site's 3 s: told 1.25 s at least), it stays online ...
    presence_sweep(now=seen + timedelta(seconds=3 * told - 0.01))
    robot.refresh_from_db()
    assert robot.presence == "online"
    # ... and flips it only once 3 told intervals have passed without a heartbeat.
    presence_sweep(now=seen + timedelta(seconds=3 * told))
    robot.refresh_from_db()
    assert robot.presence == "unreachable"


def test_the_cap_never_shortens_a_sites_own_longer_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1
    settings.HEARTBEAT_INTERVAL_MAX = 4
    type(robot.site).objects.filter(pk=robot.site.pk).update(heartbeat_interval=6.0)
    robots_heartbeating(robot.site, 20)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 6.0


# --- The meter: requests, processor time and the queue for a worker (core/busy.py) -----------


def meter_of(moments, cpu=None) -> BusyMeter:
    """A BusyMeter on a clock reading `moments` one after another (and `cpu` likewise)."""
    return BusyMeter(
        clock=iter(moments).__next__, cpu=iter(cpu or [0.0] * (len(moments) + 1)).__next__
    )


def test_a_window_counts_the_requests_and_processor_time_of_its_two_seconds():
    meter = meter_of([0.0, 0.5, 2.5], cpu=[0.0, 0.01, 0.03])

    meter.started(), meter.finished()  # 0.5 s in: 10 ms of processor
    assert meter.last is None
    meter.started(), meter.finished()  # 2.5 s in: 20 ms more; the window closes

    assert meter.last == Window(0.0, 2.5, served=2, cpu=pytest.approx(0.03))
    assert meter.last.rate == pytest.approx(0.8)


def test_a_window_carries_the_queue_on_the_watched_listening_sockets():
    listener = socket.create_server(("127.0.0.1", 0), backlog=16)
    queued = [socket.create_connection(listener.getsockname()) for _ in range(3)]
    meter = meter_of([0.0, 1.0, 2.5])
    meter.listeners_watch([listener], pool=4)
    try:
        meter.started(), meter.finished()  # 3 connections waiting to be accepted
        listener.accept()[0].close()
        meter.started(), meter.finished()  # 2
    finally:
        for connection in [*queued, listener]:
            connection.close()

    assert (meter.last.waiting, meter.last.waiting_least) == (pytest.approx(2.5), 2)
    assert meter.last.queue_stood
    assert meter.last.pool == 4


def test_a_queue_that_emptied_once_in_the_window_did_not_stand():
    window = Window(0.0, 2.0, served=100, waiting=40.0, waiting_least=0, pool=5)

    assert not window.queue_stood


def test_without_watched_sockets_the_queue_is_not_known():
    meter = meter_of([0.0, 2.0])

    meter.started(), meter.finished()

    assert (meter.last.waiting, meter.last.waiting_least, meter.last.pool) == (None, None, None)


def _requests_served(tally: Tally, count: int) -> None:
    for _ in range(count):
        tally.add(served=1, cpu=0.001)


def test_a_tally_shared_before_forking_counts_every_processs_requests():
    tally = Tally(shared=True)
    children = [
        multiprocessing.get_context("fork").Process(target=_requests_served, args=(tally, 100))
        for _ in range(3)
    ]
    for child in children:
        child.start()
    for child in children:
        child.join(timeout=30)

    served, cpu = tally.read()
    assert (served, cpu) == (300, pytest.approx(0.3))


# --- The interval learned from the queue (robots.cadence.Controller) ----------------------------


def stood(*, at=0.0, waiting=800.0, rate=200.0, cost=0.006, pool=5, least=None) -> Window:
    """A window of WINDOW_SECONDS from `at` whose queue stood, the pool serving `rate` a second,
    each request costing `cost` seconds of processor."""
    served = round(rate * WINDOW_SECONDS)
    least = int(waiting // 2) if least is None else least
    return Window(at, at + WINDOW_SECONDS, served, served * cost, waiting, least, pool)


def calm(*, at=0.0, rate=100.0, cost=0.005, waiting=1.0, pool=5) -> Window:
    """A window without a standing queue."""
    served = round(rate * WINDOW_SECONDS)
    return Window(at, at + WINDOW_SECONDS, served, served * cost, waiting, 0, pool)


def test_without_the_queue_nothing_is_learned():
    # runserver and the tests' servers hand no sockets over: no queue, no judgement.
    controller = Controller()

    controller.judge(Window(0.0, 2.0, served=400, cpu=2.0), base=1.0, robots=1000)

    assert (controller.interval, controller.cpu_share) == (0.0, 0.0)


def test_a_standing_queue_is_answered_in_one_step_by_littles_law():
    controller = Controller()

    controller.judge(stood(waiting=800, rate=200), base=1.0, robots=1000)

    # 800 waiting, 5 being served, 200 a second answered at 1 s: 1,005 robots, which at AIM of
    # the 200 a second served need 1,005 / (0.92 x 200) = 5.46 s, told in steps of 0.05 s.
    assert controller.fleet == 1005 - 5  # never more than the 1,000 robots counted
    assert controller.interval == 5.45
    assert controller.cpu_share == pytest.approx(200 * 0.006)


def test_a_queue_that_emptied_once_lengthens_nothing():
    controller = Controller()

    controller.judge(calm(rate=190, waiting=40), base=1.0, robots=1000)

    assert controller.interval == 0.0


def test_while_the_robots_hear_it_another_standing_window_asks_no_more():
    controller = Controller()
    controller.judge(stood(waiting=800), base=1.0, robots=1000)

    # The same backlog draining: the fleet judged before stands, the capacity is the same.
    controller.judge(stood(at=2.0, waiting=600), base=1.0, robots=1000)

    assert controller.interval == 5.45


def test_while_the_robots_hear_it_a_noisier_window_asks_no_more():
    controller = Controller()
    controller.judge(stood(waiting=800, rate=200), base=1.0, robots=1000)

    # Until every robot heard 5.45 s (the 4 s of the queue and 1.5 x 1 s), the queue it
    # answered stands: a window whose requests cost 10 % more is noise, not a new load.
    controller.judge(stood(at=2.0, waiting=700, rate=200, cost=0.0066), base=1.0, robots=1000)

    assert controller.interval == 5.45


def test_a_queue_standing_once_the_robots_heard_it_lengthens_by_hold_at_least():
    controller = Controller(interval=2.0, cpu_share=1.2, share_at=0.0, fleet=400, judge_from=0.0)

    # 400 robots at 2 s offer 200 a second, under the 221 that 0.92 x 1.2 / 5 ms makes; the
    # queue stood all the same (120 waiting at least: 0.6 s, more than a quarter of the 2 s),
    # so the capacity learned is too high.
    controller.judge(stood(at=1.0, waiting=240, rate=200, cost=0.005), base=1.0, robots=400)

    assert controller.interval == 2.1  # 5 % longer


def test_a_queue_that_keeps_heartbeats_waiting_a_moment_only_changes_nothing():
    controller = Controller(interval=4.5, cpu_share=1.2, share_at=0.0, fleet=1000, judge_from=0.0)

    # 1,000 robots at 4.5 s: 222 a second, the pool serving 210 with 30-45 waiting (at least
    # 30: 0.14 s, under a quarter of the interval): it serves all it can, and a longer interval
    # would cost more than the wait.
    for n in range(10):
        window = stood(at=2.0 * n, waiting=45, least=30, rate=210, cost=0.0057)
        controller.judge(window, base=1.0, robots=1000)

    assert controller.interval == 4.5
    assert controller.cpu_share == pytest.approx(1.2)  # nor a calm window: nothing shortens


def test_a_queue_at_the_sites_interval_that_the_fleet_does_not_make_lengthens_nothing():
    controller = Controller(cpu_share=1.2)

    # 40 robots at 1 s, and a burst of requests queued for two seconds (60 waiting at least:
    # 0.4 s, more than a quarter of the interval).
    controller.judge(stood(waiting=120, rate=150), base=1.0, robots=40)

    assert controller.interval == 0.0


def test_a_moments_dip_in_the_processor_the_pool_gets_is_not_learned():
    controller = Controller()
    controller.judge(stood(waiting=800, rate=200), base=1.0, robots=1000)

    # Another process took half a processor for two seconds: 120 served where 200 were.
    controller.judge(stood(at=2.0, waiting=700, rate=120), base=1.0, robots=1000)

    assert controller.cpu_share == pytest.approx(200 * 0.006)
    assert controller.interval == 5.45
    # Past SHARE_MEMORY, the pool's share is what it is now.
    controller.judge(stood(at=cadence.SHARE_MEMORY + 4, rate=120), base=1.0, robots=1000)
    assert controller.cpu_share == pytest.approx(120 * 0.006)


def test_heavier_requests_mean_a_smaller_capacity_and_lighter_ones_a_larger():
    controller = Controller()
    # A fleet starting: every first heartbeat of a boot costs three times a plain one.
    controller.judge(stood(waiting=900, rate=70, cost=0.018), base=1.0, robots=1000)
    assert controller.interval == 10.0  # 1,000 / (0.92 x 70) = 15.5 s, capped

    # Once the robots heard it (1.5 s after the 1 s they were told, and the queue's 13 s),
    # plain heartbeats over one whole interval without a queue: the capacity for them is the
    # same share of the processor over 6 ms x LOADED_COST a request: 191 a second.
    judged_from = 2.0 + 905 / 70 + 1.5
    for n in range(5):
        controller.judge(calm(at=judged_from + 2 * n, rate=100, cost=0.006), base=1.0, robots=1000)

    capacity = 70 * 0.018 / (0.006 * cadence.LOADED_COST)
    fleet = min(1 + 5 + 100 * 10.0, 1000)  # Little's count, never more than the robots
    steps = math.ceil(fleet / (AIM * capacity) / cadence.LEARNED_STEP)  # 5.69 s: 5.7 s
    assert controller.interval == pytest.approx(steps * cadence.LEARNED_STEP)
    assert controller.interval < 6.0


def test_it_shortens_only_once_the_robots_heard_the_interval_and_over_a_whole_one():
    controller = Controller(interval=6.0, cpu_share=1.2, fleet=1000, judge_from=10.0)

    controller.judge(calm(at=8.0, rate=50), base=1.0, robots=1000)  # began before 10 s
    controller.judge(calm(at=10.0, rate=50), base=1.0, robots=1000)
    controller.judge(calm(at=12.0, rate=50), base=1.0, robots=1000)
    assert controller.interval == 6.0  # 4 s gathered, not yet the 6 s interval

    controller.judge(calm(at=14.0, rate=50), base=1.0, robots=1000)

    # 50 a second at 6 s with 1 waiting: 306 robots; 1.2 / (5 ms x 1.1) = 218 a second.
    assert controller.interval == 1.55  # 306 / (0.92 x 218) = 1.52 s


def test_it_never_shortens_below_the_sites_interval():
    controller = Controller(interval=6.0, cpu_share=1.2, fleet=1000)

    for n in range(4):
        controller.judge(calm(at=2.0 * n, rate=5), base=1.5, robots=1000)

    assert max(controller.interval, 1.5) == 1.5


def test_the_learned_interval_is_capped_and_never_shortens_a_sites_longer_one(settings):
    settings.HEARTBEAT_INTERVAL_MAX = 4
    controller = Controller()
    controller.judge(stood(waiting=800), base=1.0, robots=1000)
    assert controller.interval == 4.0

    controller = Controller()
    controller.judge(stood(waiting=800), base=6.0, robots=1000)
    assert max(controller.interval, 6.0) == 6.0


def test_at_the_aim_it_probes_for_more_only_after_a_quiet_while():
    # 1,000 robots told 5.45 s, at the aim of the 199 a second learned (1.2 of a processor at
    # 5 ms x LOADED_COST a request), the queue last standing at 0 s.
    controller = Controller(interval=5.45, cpu_share=1.2, fleet=1000, stood_at=0.0)
    cost = 1.2 / (1000 / (AIM * 5.45) * cadence.LOADED_COST)

    def calm_interval(at: float) -> None:
        """Calm windows over the whole interval, the robots offering what it makes them."""
        controller.judge_from = 0.0
        for n in range(3):
            window = calm(at=at + 2 * n, rate=1000 / controller.interval, cost=cost)
            controller.judge(window, base=1.0, robots=1000)

    calm_interval(PROBE_QUIET - 10)
    assert controller.interval == 5.45  # soon after the queue stood: it holds
    calm_interval(PROBE_QUIET + 10)
    assert controller.cpu_share == pytest.approx(1.2 * (1 + PROBE))  # then looks for more
    assert controller.interval == 5.2
    calm_interval(PROBE_QUIET + 40)
    assert controller.cpu_share == pytest.approx(1.2 * (1 + PROBE) * (1 + 2 * PROBE))
    assert controller.interval == 4.75


# --- The model: a fleet against a pool (tests/robots/pool_model.py) -------------------------------


@pytest.mark.parametrize(
    ("robots", "capacity"), [(1000, 190), (500, 190), (200, 190), (1000, 700), (300, 120)]
)
def test_past_capacity_the_fleet_settles_near_the_aim_with_no_long_queue_or_flip(robots, capacity):
    run = pool_model.run(Controller(), robots=robots, capacity=capacity, seconds=300)

    assert 0.85 * capacity <= run.rate(60, 300) <= 1.001 * capacity
    # Where the capacity learned is too high a short queue may stand: it is tolerated.
    told = max(run.intervals(60, 300))
    assert run.waited(60, 300, 50) < cadence.QUEUE_TOLERATED * told + 0.05
    assert not [at for at in run.flips if at > 20]


def test_under_capacity_it_never_lengthens():
    run = pool_model.run(Controller(), robots=150, capacity=190, seconds=120)

    assert run.intervals(0, 120) == {1.0}
    assert run.rate(10, 120) == pytest.approx(150 / 1.026, rel=0.02)  # 1 s after each answer


def test_a_fleet_starting_at_once_with_heavy_first_heartbeats_comes_back_to_the_aim():
    # The first heartbeat of each boot costs 3 times a plain one: the first capacity learned is
    # a third of the steady one. Told 10 s at first, the fleet is back near the aim in a minute.
    run = pool_model.run(Controller(), robots=1000, capacity=190, seconds=240, first_cost=3.0)

    assert max(run.intervals(0, 20)) == 10.0
    assert run.rate(90, 240) >= 0.85 * 190
    assert not [at for at in run.flips if at > 30]


def test_it_follows_the_machine_down_and_finds_it_again_when_it_recovers():
    def capacity(second: float) -> float:
        return 100 if 60 <= second < 120 else 190

    run = pool_model.run(Controller(), robots=1000, capacity=capacity, seconds=420)

    assert run.rate(20, 60) >= 0.85 * 190
    assert max(run.intervals(70, 120)) == 10.0  # 1,000 / (0.92 x 100) = 10.9 s, capped
    assert run.rate(300, 420) >= 0.85 * 190  # probed back within three minutes


# --- Presence while heartbeats wait for a worker (robots.cadence.heartbeat_backlog) -------------


def test_while_heartbeats_wait_for_a_worker_the_sweep_gives_robots_that_long(robot, settings):
    robot.mark_seen(timezone.now() - timedelta(seconds=10))  # told 1 s: overdue by 7 s
    robot.save()
    backlog(8.0, at=timezone.now())

    presence_sweep()
    robot.refresh_from_db()
    assert robot.presence == "online"  # its heartbeat may be in our queue

    backlog(6.0, at=timezone.now())
    presence_sweep()
    robot.refresh_from_db()
    assert robot.presence == "unreachable"  # overdue by more than the server is late


def test_a_backlog_no_process_reported_lately_is_over(robot):
    now = timezone.now()
    backlog(30.0, at=now - cadence.BACKLOG_FRESH)

    assert heartbeat_backlog(now) == 0.0
    assert heartbeat_backlog(now - timedelta(seconds=1)) == 30.0


def backlog(seconds: float, *, at) -> None:
    HeartbeatCadence.objects.update_or_create(
        pk=1, defaults={"backlog_seconds": seconds, "backlog_at": at}
    )


def test_a_saturated_window_reports_its_backlog(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000
    shared()
    busy.last = stood_now(waiting=400, rate=200)

    robot_http.heartbeat(1)

    assert HeartbeatCadence.objects.get(pk=1).backlog_seconds == pytest.approx(2.0)  # 400 / 200


def stood_now(**fields) -> Window:
    """A window whose queue stood, just closed."""
    window = stood(**fields)
    return Window(
        time.monotonic() - WINDOW_SECONDS,
        time.monotonic(),
        window.served,
        window.cpu,
        window.waiting,
        window.waiting_least,
        window.pool,
    )


# --- Over HTTP: what robots are told, and one interval for every web process ------------------

# 20 robots heartbeating (R1 is not counted before it is first seen) against a pool that served
# 10 a second with the queue standing: 20 / (0.92 x 10) = 2.17 s, told 2.2 s.
SATURATED = 2.2


def saturated(site) -> None:
    """As if the process serving heartbeats had just closed a window whose queue stood."""
    robots_heartbeating(site, 20)
    busy.last = stood_now(waiting=10, rate=10)


def shared(interval: float = 0.0, changed_at=None) -> None:
    """The shared row as another process left it (flushed tables lose the migration's row)."""
    HeartbeatCadence.objects.update_or_create(
        pk=1, defaults={"interval": interval, "cpu_share": 0.05, "changed_at": changed_at}
    )


def test_a_saturated_server_tells_robots_a_longer_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000  # the ceiling far away: the queue decides
    saturated(robot.site)

    told = robot_http.heartbeat(1)["heartbeat_interval"]

    assert told == factories.interval_told(robot, SATURATED)


def test_a_robot_that_obeys_a_learned_interval_is_not_flipped(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000
    saturated(robot.site)
    told = robot_http.heartbeat(1)["heartbeat_interval"]
    robot.refresh_from_db()
    seen = robot.last_seen_at

    presence_sweep(now=seen + timedelta(seconds=3 * told - 0.01))  # past the site's 3 s
    robot.refresh_from_db()
    assert robot.presence == "online"
    assert robot.unreachable_at - seen == timedelta(seconds=3 * told)


def test_under_the_ceilings_interval_it_lengthens_from_that_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10  # 21 robots: 2.5 s by the ceiling
    robots_heartbeating(robot.site, 20)
    busy.last = stood_now(waiting=10, rate=5)

    # 20 robots (not the 10 + 5 + 5 x 2.5 Little counts) at 0.92 x 5 a second: 4.35 s.
    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 4.35)


def test_a_zero_ceiling_turns_the_learned_interval_off(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 0
    saturated(robot.site)

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 1.0


def test_a_processs_decision_is_written_for_the_others(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000
    shared()
    saturated(robot.site)

    robot_http.heartbeat(1)

    row = HeartbeatCadence.objects.get(pk=1)
    assert (row.interval, row.cpu_share) == (SATURATED, pytest.approx(10 * 0.006))


def test_another_processs_decision_is_adopted(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000
    shared(3.0, timezone.now())

    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 3.0)


def test_an_adopted_decision_is_not_judged_again_until_its_queue_has_drained(
    robot_http, robot, settings
):
    settings.HEARTBEAT_CAPACITY = 1000
    shared(3.0, timezone.now())
    backlog(4.0, at=timezone.now())  # the other process's queue: 4 s
    robot_http.heartbeat(1)  # heard and adopted
    robots_heartbeating(robot.site, 20)

    # 2 s later (past the 1.5 s of the interval before, not the queue's 4 s more), a window
    # whose queue stood, 15 waiting at least (1.5 s at 10 a second: no short queue): robots
    # still on 1 s make it, and it asks nothing more.
    judged_from = time.monotonic() + 2.0
    busy.last = Window(judged_from, judged_from + 2.0, 20, 0.12, 20, 15, 5)
    assert robot_http.heartbeat(2)["heartbeat_interval"] == factories.interval_told(robot, 3.0)
    assert HeartbeatCadence.objects.get(pk=1).interval == 3.0


def test_a_decision_gives_way_to_one_another_process_wrote_since_this_one_heard(
    robot_http, robot, settings
):
    settings.HEARTBEAT_CAPACITY = 1000
    cadence._shared.read_at = time.monotonic()  # it read the row just before: not again yet
    shared(3.5, timezone.now())  # another process, judging the same load, wrote meanwhile
    saturated(robot.site)  # this one would ask 2.2 s

    told = robot_http.heartbeat(1)["heartbeat_interval"]

    # Its conditional UPDATE found the row changed: the other's decision stands.
    assert told == factories.interval_told(robot, 3.5)
    assert HeartbeatCadence.objects.get(pk=1).interval == 3.5
