"""The heartbeat cadence under real gunicorn (robots/cadence.py, core/busy.py,
hospital_delivery/gunicorn_hooks.py): robots arriving faster than two sync workers serve them
leave a queue on gunicorn's listening socket, which every worker reads from the kernel, and the
requests they serve are counted for the pool in memory the master shared before forking them.
The robots answered once the queue has stood for a window are told a longer interval, every
worker tells the same one, and the presence sweep is told how long heartbeats wait."""

import threading
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
        told = _heartbeats_at_once(url, fleet)

    assert len(told) == ROBOTS
    assert told[0] == 1.0  # before the queue stood for a window
    assert told[-1] > 1.5, told  # after it did
    row = HeartbeatCadence.objects.get(pk=1)
    assert row.interval > 1.5
    assert row.backlog_at is not None
    assert row.backlog_seconds > 0.2
    assert row.cpu_share > 0


def test_the_sweep_holds_robots_whose_heartbeats_are_in_the_queue(fleet):
    late, flooding = fleet[-1], fleet[:-1]  # one robot silent while the others flood the server
    env = {"HEARTBEAT_CAPACITY": "100000"}
    with servers.gunicorn(workers=2, env=env) as url:
        flood = threading.Thread(target=_heartbeats_at_once, args=(url, flooding))
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


def _heartbeats_at_once(url: str, robots) -> list[float]:
    """Every robot's heartbeat sent at once, each on its own connection; the intervals told, in
    the order the answers came."""
    told, lock = [], threading.Lock()
    ready = threading.Barrier(len(robots))

    def heartbeat(robot) -> None:
        session = requests.Session()
        body = factories.heartbeat_body(1, boot_id=f"boot-{robot.code}")
        headers = {"Authorization": f"Bearer {robot.token}"}
        ready.wait(timeout=60)
        answer = session.post(
            f"{url}/api/v1/robots/{robot.code}/heartbeat", json=body, headers=headers, timeout=60
        )
        assert answer.status_code == 200, answer.text
        with lock:
            told.append(answer.json()["heartbeat_interval"])

    with ThreadPoolExecutor(max_workers=len(robots)) as pool:
        list(pool.map(heartbeat, robots))
    return told
