"""The heartbeat cadence under real gunicorn (robots/cadence.py, core/busy.py,
hospital_delivery/gunicorn_hooks.py): robots arriving faster than two sync workers serve them
leave a queue on gunicorn's listening socket, which every worker reads from the kernel, and the
requests they serve are counted for the pool in memory the master shared before forking them.
The robots answered once the queue has stood for a window are told a longer interval, every
worker tells the same one, and the presence sweep is told how long heartbeats wait."""

import itertools
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import timedelta

import pytest
import requests

from robots.models import HeartbeatCadence, Robot
from robots.services import presence_sweep
from tests import factories, servers

ROBOTS = 400  # about three seconds of work for two workers on our 2-core machines

pytestmark = pytest.mark.slow


@pytest.fixture
def fleet(transactional_db, site):
    """ROBOTS robots already heartbeating (a running fleet, counted by the cadence)."""
    robots = [factories.robot_create(site, f"F{n}") for n in range(ROBOTS)]
    Robot.objects.filter(pk__in=[robot.pk for robot in robots]).update(presence="online")
    return robots


def test_robots_past_what_two_workers_serve_are_told_a_longer_interval(fleet):
    env = {"HEARTBEAT_CAPACITY": "100000"}  # the operator's ceiling far away: the queue decides
    with servers.gunicorn(workers=2, env=env) as url:
        told = _heartbeats(url, fleet, until_longer=True)

    assert len(told) >= ROBOTS
    assert told[0] == 1.0  # before the queue stood for a window
    assert max(told) > 1.5, told[-20:]  # after it did
    row = HeartbeatCadence.objects.get(pk=1)
    assert row.interval > 1.5
    assert row.backlog_at is not None
    assert row.backlog_seconds > 0.2
    assert row.cpu_share > 0


def test_the_sweep_holds_robots_whose_heartbeats_are_in_the_queue(fleet):
    late, flooding = fleet[-1], fleet[:-1]  # one robot silent while the others flood the server
    env = {"HEARTBEAT_CAPACITY": "100000"}
    with servers.gunicorn(workers=2, env=env) as url:
        flood = threading.Thread(target=_heartbeats, args=(url, flooding))
        flood.start()
        reported = servers.poll(
            lambda: HeartbeatCadence.objects.filter(pk=1, backlog_at__isnull=False).first(),
            what="a backlog reported",
        )
        # Its deadline passed, by less than heartbeats wait for a worker: its heartbeat may be
        # one of those in the queue.
        overdue = timedelta(seconds=reported.backlog_seconds / 2)
        Robot.objects.filter(pk=late.pk).update(
            last_seen_at=reported.backlog_at - timedelta(seconds=10),
            unreachable_at=reported.backlog_at - overdue,
            offline_at=reported.backlog_at + timedelta(minutes=5),
        )
        presence_sweep(now=reported.backlog_at)
        late.refresh_from_db()
        assert late.presence == "online"
        # Once overdue by more than that, the robot, not the server, is late.
        presence_sweep(now=reported.backlog_at + 2 * overdue)
        late.refresh_from_db()
        assert late.presence == "unreachable"
        flood.join()


def _heartbeats(url: str, robots, *, until_longer: bool = False, seconds: float = 60.0):
    """Every robot's heartbeat sent at once, each on its own connection; with `until_longer`,
    each robot's next as soon as it is answered, until one is told more than 1.5 s (or `seconds`
    pass). The intervals told, in the order the answers came.

    One wave does not always make the cadence lengthen: a window that opens as the wave arrives
    reads the queue nearly empty at its first request, and the wave may be served before a
    window stands whole behind it (a wait under a quarter of the interval is tolerated, and two
    workers served 400 robots in about 4 s: 2 windows)."""
    told, lock, longer = [], threading.Lock(), threading.Event()
    ready = threading.Barrier(len(robots))
    deadline = time.monotonic() + seconds

    def heartbeats(robot) -> None:
        session = requests.Session()
        headers = {"Authorization": f"Bearer {robot.token}"}
        ready.wait(timeout=60)
        for seq in itertools.count(1):
            body = factories.heartbeat_body(seq, boot_id=f"boot-{robot.code}")
            answer = session.post(
                f"{url}/api/v1/robots/{robot.code}/heartbeat",
                json=body,
                headers=headers,
                timeout=60,
            )
            assert answer.status_code == 200, answer.text
            interval = answer.json()["heartbeat_interval"]
            with lock:
                told.append(interval)
            if interval > 1.5:
                longer.set()
            if not until_longer or longer.is_set() or time.monotonic() > deadline:
                return

    with ThreadPoolExecutor(max_workers=len(robots)) as pool:
        list(pool.map(heartbeats, robots))
    return told
