"""The heartbeat interval told to robots follows the load (robots/cadence.py): the robots not
offline against the operator's ceiling, and how busy the web workers are (core/busy.py); and
presence deadlines follow the interval each robot was told, so a robot that obeys is never
flipped. The controller is fed windows of the busy share directly: no clock, no sleep."""

import heapq
import socket
import time
from datetime import timedelta

import pytest

from core.busy import BusyMeter, Window, busy
from robots.cadence import HIGH_SHARE, STEP_SECONDS, WAITING_HIGH, Controller, cadence_forget
from robots.models import Robot
from robots.services import presence_sweep
from tests import factories


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


# --- The interval learned from how busy the web workers are --------------------------------------

WINDOW = 2.0  # seconds of each busy-share window the tests feed the controller


def windows(controller, shares, *, base=1.0, start=0.0):
    """Feed one window per share, back to back; the interval after each."""
    told = []
    for n, share in enumerate(shares):
        at = start + n * WINDOW
        controller.judge(Window(at, at + WINDOW, share), base=base)
        told.append(max(controller.interval, base))
    return told


def test_it_lengthens_the_interval_while_the_workers_are_saturated():
    controller = Controller()

    told = windows(controller, [1.0] * 7)

    # Aimed at a share of 0.6: 1 s x 1.0/0.6 -> 2 s; then no window is judged until every robot
    # has heard it (the 1 s before), and judgements take windows covering one whole interval:
    # the next 2 s window lengthens it again, 2 s x 1.67 -> 3.5 s, which then takes two windows.
    assert told == [2.0, 2.0, 3.5, 3.5, 3.5, 6.0, 6.0]


def test_a_busy_share_without_a_queue_does_not_lengthen_it():
    """Where gunicorn hands over its sockets, the queue on them decides whether the busy share
    means saturation: about 83 % read both at 95 % of what the pool takes (a few connections
    waiting) and past it (hundreds), 2026-11-25."""
    controller = Controller(interval=1.5)
    busy_without_queue = Window(0.0, WINDOW, 0.9, waiting=WAITING_HIGH / 2)
    busy_with_queue = Window(WINDOW, 2 * WINDOW, 0.9, waiting=WAITING_HIGH * 10)

    controller.judge(busy_without_queue, base=1.0)
    assert controller.interval == 1.5
    controller.judge(busy_with_queue, base=1.0)
    assert controller.interval == 2.5  # 1.5 s x 0.9/0.6, in steps of 0.5 s


def test_a_queue_without_a_busy_share_does_not_lengthen_it():
    # A moment's bunch of connections while the workers are mostly idle over the interval.
    controller = Controller(interval=1.5)

    controller.judge(Window(0.0, WINDOW, 0.5, waiting=WAITING_HIGH * 10), base=1.0)

    assert controller.interval == 1.5


def test_it_does_not_judge_the_windows_before_every_robot_heard_the_new_interval():
    controller = Controller()
    windows(controller, [1.0])
    assert controller.interval == 2.0

    # The window starting at 2 s began before 2 s + the 1 s interval robots were told before.
    controller.judge(Window(2.5, 4.5, 1.0), base=1.0)
    assert controller.interval == 2.0
    controller.judge(Window(3.0, 5.0, 1.0), base=1.0)
    assert controller.interval == 3.5


def test_it_judges_the_share_over_a_whole_interval_not_one_short_window():
    controller = Controller(interval=6.0)

    # At 6 s, a 2 s window of a bunch of robots, then two of the gap after it: 40 % busy in all.
    assert windows(controller, [1.0, 0.1, 0.1]) == [6.0, 6.0, 6.0]
    # Had the first window alone been judged, it would have lengthened it to 10 s.


def test_a_window_is_judged_once():
    controller = Controller(interval=3.0)
    window = Window(0.0, WINDOW, 0.1)

    controller.judge(window, base=1.0)
    controller.judge(window, base=1.0)  # not gathered twice: 2 s is not yet the 3 s interval

    assert controller.interval == 3.0
    controller.judge(Window(WINDOW, 2 * WINDOW, 0.1), base=1.0)
    assert controller.interval == 1.0


def test_it_shortens_towards_the_aim_when_the_load_falls_and_never_below_the_site():
    controller = Controller(interval=3.0)

    assert windows(controller, [0.05] * 4) == [3.0] + [1.0] * 3  # judged once 3 s are seen
    assert controller.interval == 1.0


def test_after_a_burst_it_comes_back_in_one_judgement_not_step_by_step():
    controller = Controller(interval=10.0)

    # 20 % busy over the 10 s interval: 10 x 0.2 / 0.6 = 3.3 s, told in whole steps: 3.5 s.
    assert windows(controller, [0.2] * 5) == [10.0] * 4 + [3.5]


def test_it_holds_between_the_thresholds():
    controller = Controller(interval=3.0)

    # 0.35 at 3 s would be 0.42 at 2.5 s: over LOW_SHARE, so it stays.
    assert windows(controller, [0.7, 0.5, 0.35, 0.79]) == [3.0] * 4


def test_the_learned_interval_is_bounded_by_the_cap(settings):
    settings.HEARTBEAT_INTERVAL_MAX = 4
    controller = Controller()

    assert max(windows(controller, [1.0] * 20)) == 4.0


def test_the_cap_never_lowers_a_sites_own_longer_interval(settings):
    settings.HEARTBEAT_INTERVAL_MAX = 4
    controller = Controller()

    assert set(windows(controller, [1.0] * 10, base=6.0)) == {6.0}


def test_a_light_load_never_lengthens_it():
    controller = Controller()

    assert set(windows(controller, [0.0, 0.3, 0.8, 0.5] * 10)) == {1.0}


def pool_share(robots, interval, *, capacity=140.0):
    """A pool of 5 sync workers on 2 cores taking `capacity` heartbeats/s when saturated: the
    share of a worker's time serving, as processor sharing makes it (steeper than the rate)."""
    load = robots / interval / capacity  # of the CPUs
    if load >= 1:
        return 1.0
    in_service = 2 * load / (1 - load * load)
    return min(in_service / 5, 1.0)


@pytest.mark.parametrize("robots", [150, 200, 500, 1000])
def test_a_steady_load_settles_on_one_interval_in_whole_steps(robots):
    controller = Controller()
    told = []
    for n in range(200):
        share = pool_share(robots, max(controller.interval, 1.0))
        controller.judge(Window(n * WINDOW, (n + 1) * WINDOW, share), base=1.0)
        told.append(max(controller.interval, 1.0))

    settled = told[30:]
    assert len(set(settled)) == 1, sorted(set(told))
    assert settled[0] / STEP_SECONDS == int(settled[0] / STEP_SECONDS)
    # Settled where the workers are not saturated, the load under the 140/s they take.
    assert pool_share(robots, settled[0]) <= HIGH_SHARE
    assert robots / settled[0] < 140


def test_it_follows_a_load_that_rises_then_falls():
    controller = Controller()
    told = []
    for n, robots in enumerate([100] * 20 + [800] * 40 + [100] * 150):
        share = pool_share(robots, max(controller.interval, 1.0))
        controller.judge(Window(n * WINDOW, (n + 1) * WINDOW, share), base=1.0)
        told.append(max(controller.interval, 1.0))

    assert told[19] == 1.0
    assert told[59] > 5.7  # 800 robots at 140/s need 5.7 s at least
    assert told[-1] == 1.0
    # Loaded, it never goes back under what the load needs once there; unloaded, never up.
    enough = told.index(next(t for t in told if t > 5.7))
    assert min(told[enough:60]) > 5.7
    assert told[60:] == sorted(told[60:], reverse=True)


def start_up(controller, robots, *, capacity, seconds):
    """Robots all starting at 1 Hz against a server taking `capacity` heartbeats/s one after the
    other (first come, first served), each robot sending its next heartbeat the interval it was
    told after its answer; the server's busy share closed into windows as core.busy does.
    Returns (answered at, interval told) per heartbeat."""
    service = 1.0 / capacity
    due = [(n / robots, n) for n in range(robots)]  # phases spread over the first second
    heapq.heapify(due)
    free = window_start = window_busy = 0.0
    told = []
    while due and due[0][0] < seconds:
        sent, robot = heapq.heappop(due)
        free = max(sent, free) + service
        window_busy += service
        if free - window_start >= WINDOW:
            share = min(window_busy / (free - window_start), 1.0)
            controller.judge(Window(window_start, free, share), base=1.0)
            window_start, window_busy = free, 0.0
        interval = max(controller.interval, 1.0)
        told.append((free, interval))
        heapq.heappush(due, (free + interval, robot))
    return told


@pytest.mark.parametrize(("robots", "capacity"), [(500, 140), (1000, 200)])
def test_after_a_start_up_backlog_it_settles_instead_of_swinging(robots, capacity):
    # The first second's heartbeats queue; answered at the server's pace, the robots come back
    # bunched, and a 2 s window sees the bunch or the gap after it. Judged on such windows the
    # interval swung between 6 and 10 s for as long as it ran (2026-11-24).
    told = start_up(Controller(), robots, capacity=capacity, seconds=300)

    settled = {interval for at, interval in told if at > 60}
    assert len(settled) == 1, sorted(settled)
    (interval,) = settled
    assert 0.4 < robots / interval / capacity <= HIGH_SHARE  # neither saturated nor idle


def test_the_busy_share_is_the_time_spent_serving_over_a_window():
    clock = iter([0.0, 0.5, 1.0, 1.2, 1.5, 2.5]).__next__
    meter = BusyMeter(clock=clock, window=2.0)

    meter.started(), meter.finished()  # 0.5 s serving
    meter.started()  # two requests overlap from 1.0 to 2.5: 1.5 s serving, counted once
    meter.started()
    assert meter.last is None
    meter.finished()
    meter.finished()

    # 2.0 s serving, and the one pause (0.5 s) is the shortest seen: the work between requests.
    assert meter.last == Window(0.0, 2.5, 1.0)


def test_a_window_carries_the_mean_queue_on_the_watched_listening_sockets():
    listener = socket.create_server(("127.0.0.1", 0), backlog=16)
    queued = [socket.create_connection(listener.getsockname()) for _ in range(3)]
    clock = iter([0.0, 1.0, 1.5, 2.5]).__next__
    meter = BusyMeter(clock=clock, window=2.0)
    meter.listeners_watch([listener])
    try:
        meter.started(), meter.finished()  # 3 connections waiting to be accepted
        listener.accept()[0].close()
        meter.started(), meter.finished()  # 2
    finally:
        for connection in [*queued, listener]:
            connection.close()

    assert meter.last.waiting == pytest.approx(2.5)


def test_without_watched_sockets_the_queue_is_not_known():
    meter = BusyMeter(clock=iter([0.0, 2.0]).__next__, window=2.0)

    meter.started(), meter.finished()

    assert meter.last.waiting is None


def share_of(requests: list[tuple[float, float]]) -> float:
    """The share a BusyMeter reads from requests served one after another, (start, end) each."""
    clock = iter([moment for request in requests for moment in request]).__next__
    meter = BusyMeter(clock=clock, window=2.0)
    for _ in requests:
        meter.started(), meter.finished()
    return meter.last.share


def test_a_worker_going_from_request_to_request_is_read_as_saturated():
    # 0.15 s per request, then 0.05 s outside what the middleware times (gunicorn reading the
    # next request, closing the last connection) before the next: saturated, not 75 % busy.
    requests = [(n * 0.2, n * 0.2 + 0.15) for n in range(11)]

    assert share_of(requests) == pytest.approx(1.0)


def test_pauses_count_as_busy_only_up_to_the_shortest_and_to_a_requests_time():
    # One robot a second: 10 ms requests, 990 ms pauses of which 10 ms count (a request's time).
    assert share_of([(n, n + 0.01) for n in range(4)]) == pytest.approx((0.03 + 0.02) / 2.01)
    # Light load with one request straight after another (20 ms): every pause counts 20 ms.
    requests = [(0.0, 0.1), (0.12, 0.22), (1.12, 1.22), (2.12, 2.22)]
    assert share_of(requests) == pytest.approx((0.4 + 3 * 0.02) / 2.22)


def saturated():
    """As if the process serving heartbeats had just spent a whole window serving."""
    busy.last = Window(time.monotonic() - WINDOW, time.monotonic(), 1.0)


def test_under_the_ceilings_interval_it_lengthens_from_that_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 10  # 21 robots: 2.5 s by the ceiling
    robots_heartbeating(robot.site, 20)
    busy.last = Window(time.monotonic() - 3.0, time.monotonic(), 1.0)  # one 2.5 s interval

    # Saturated while robots are told 2.5 s: 2.5 x 1.0/0.6 -> 4.5 s. Judged from its own 1 s
    # the controller asked 2 s, and robots were told the ceiling's 2.5 s still.
    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 4.5)


def test_a_saturated_server_tells_robots_a_longer_interval(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000  # the ceiling far away: the busy share decides
    saturated()

    assert robot_http.heartbeat(1)["heartbeat_interval"] == factories.interval_told(robot, 2.0)


def test_a_robot_that_obeys_a_learned_interval_is_not_flipped(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 1000
    saturated()
    told = robot_http.heartbeat(1)["heartbeat_interval"]
    robot.refresh_from_db()
    seen = robot.last_seen_at

    assert told == factories.interval_told(robot, 2.0)
    presence_sweep(now=seen + timedelta(seconds=3 * told - 0.01))  # past the site's 3 s
    robot.refresh_from_db()
    assert robot.presence == "online"
    assert robot.unreachable_at - seen == timedelta(seconds=3 * told)


def test_a_zero_ceiling_turns_the_learned_interval_off(robot_http, robot, settings):
    settings.HEARTBEAT_CAPACITY = 0
    saturated()

    assert robot_http.heartbeat(1)["heartbeat_interval"] == 1.0
