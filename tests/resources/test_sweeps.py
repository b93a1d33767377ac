"""Grant expiry, the hard limit, force-release and offline robots, with driven time.

Each sweep is given its `now`; deadlines are reached by moving `now` (or a stored time), never
by sleeping. Leases are made through the services here; tests/resources/test_leases_http.py shows
the same flows over HTTP.
"""

import threading
from datetime import timedelta

import pytest
from django.db import connections
from django.utils import timezone

from boards.models import BoardMessage
from resources import tasks
from resources.leases import lease_expire, lease_revoke, lease_sweep
from resources.models import Lease
from robots.alerts import alert_acknowledge
from robots.models import Alert, Robot
from robots.services import presence_sweep
from tests import factories
from tests.factories import lease_acquire, lease_enter
from tests.resources.conftest import holders, messages_about, resource

SECOND = timedelta(seconds=1)
TICK = timedelta(microseconds=1)


@pytest.fixture
def t0():
    return timezone.now()


@pytest.fixture
def make_robot(site, t0):
    """Robots heard from at t0 (online), standing on 1F."""

    def make(code: str) -> Robot:
        robot = factories.robot_create(site, code, floor=site.floors.get(code="1F"))
        robot.mark_seen(t0)
        robot.save(update_fields=Robot.PRESENCE_FIELDS)
        return robot

    return make


def board(robot) -> list[tuple[str, dict]]:
    pending = BoardMessage.objects.pending().filter(robot=robot).order_by("id")
    return [(message.type, message.body) for message in pending]


def ask(robot, code="ELEV", *, at, request_id=None):
    return lease_acquire(
        robot=robot,
        resource=resource(code),
        request_id=request_id or f"q-{robot.code}",
        to_floor="2F" if code == "ELEV" else None,
        now=at,
    )


def reloaded(lease) -> Lease:
    return Lease.objects.get(pk=lease.pk)


def test_it_expires_a_grant_not_taken_up_and_grants_the_next_in_line(make_robot, t0):
    a, b = make_robot("RA"), make_robot("RB")
    first = ask(a, at=t0)
    second = ask(b, at=t0 + SECOND)

    assert lease_sweep(now=t0 + 60 * SECOND - TICK)["expired"] == 0
    swept = lease_sweep(now=t0 + 60 * SECOND)

    assert swept == {"expired": 1, "alerted": 0}
    first = reloaded(first)
    assert (first.state, first.end_cause, first.ended_at) == (
        "expired",
        "grant_timeout",
        t0 + 60 * SECOND,
    )
    second = reloaded(second)
    assert (second.state, second.granted_at, second.expires_at) == (
        "granted",
        t0 + 60 * SECOND,
        t0 + 120 * SECOND,
    )
    assert board(a) == []  # the stale grant is withdrawn
    assert board(b) == [
        (
            "resource_grant",
            {
                "request": "q-RB",
                "resource": "ELEV",
                "lease": second.public_id,
                "expires_at": (t0 + 120 * SECOND).isoformat(timespec="milliseconds")[:-6] + "Z",
                "to_floor": "2F",
            },
        )
    ]


def test_it_never_expires_a_grant_entered_in_time(make_robot, t0):
    a = make_robot("RA")
    lease = ask(a, at=t0)
    lease_enter(robot=a, resource=resource("ELEV"), now=t0 + 59 * SECOND)

    assert lease_sweep(now=t0 + 3600 * SECOND)["expired"] == 0
    assert reloaded(lease).state == "entered"


def test_it_expires_and_grants_nothing_for_a_sweeper_that_lost_the_race(make_robot, t0):
    a, b = make_robot("RA"), make_robot("RB")
    stale_copy = ask(a, at=t0)
    waiting = ask(b, at=t0)
    due = t0 + 60 * SECOND

    assert lease_expire(lease=stale_copy, now=due) is True
    assert lease_expire(lease=stale_copy, now=due) is False
    lease_sweep(now=due)

    assert reloaded(waiting).granted_at == due
    assert len(messages_about(waiting, "resource_grant")) == 1


def test_it_expires_and_grants_each_lease_once_with_two_sweepers_at_once(
    transactional_db, make_robot, t0
):
    a, b = make_robot("RA"), make_robot("RB")
    ask(a, at=t0)
    waiting = ask(b, at=t0)
    start, results = threading.Barrier(2), []

    def sweeper():
        try:
            start.wait()
            results.append(lease_sweep(now=t0 + 60 * SECOND))
        finally:
            connections.close_all()

    threads = [threading.Thread(target=sweeper) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30)

    assert sorted(result["expired"] for result in results) == [0, 1]
    assert holders("ELEV") == ["RB"]
    assert len(messages_about(waiting, "resource_grant")) == 1


def test_it_alerts_about_a_silent_robot_inside_past_the_hard_limit_and_keeps_its_lease(
    make_robot, t0
):
    a, b = make_robot("RA"), make_robot("RB")
    inside = ask(a, at=t0)
    lease_enter(robot=a, resource=resource("ELEV"), now=t0)
    waiting = ask(b, at=t0)
    limit = 900 * SECOND  # the site's lease_hard_limit

    assert lease_sweep(now=t0 + limit - TICK)["alerted"] == 0
    assert lease_sweep(now=t0 + limit)["alerted"] == 1

    alert = Alert.objects.open().get()
    assert (alert.kind, alert.key, alert.robot, alert.resource.code) == (
        "lease_hard_limit",
        f"lease-hard-limit:{inside.pk}",
        a,
        "ELEV",
    )
    assert inside.public_id in alert.message
    assert reloaded(inside).state == "entered"
    assert reloaded(waiting).state == "queued"
    assert messages_about(waiting, "resource_grant") == []


def test_it_alerts_once_per_silence_even_after_acknowledgement(make_robot, t0, staff):
    a = make_robot("RA")
    ask(a, at=t0)
    lease_enter(robot=a, resource=resource("ELEV"), now=t0)
    lease_sweep(now=t0 + 900 * SECOND)
    alert_acknowledge(alert=Alert.objects.get(), user=staff)

    assert lease_sweep(now=t0 + 2000 * SECOND)["alerted"] == 0
    assert not Alert.objects.open().exists()

    a.mark_seen(t0 + 2000 * SECOND)  # heard from again, then silent again
    a.save(update_fields=Robot.PRESENCE_FIELDS)
    assert lease_sweep(now=t0 + 2899 * SECOND)["alerted"] == 0
    assert lease_sweep(now=t0 + 2900 * SECOND)["alerted"] == 1
    assert Alert.objects.open().count() == 1


def test_it_grants_the_next_on_force_release_and_acknowledges_the_alert(
    make_robot, t0, staff, django_capture_on_commit_callbacks
):
    a, b = make_robot("RA"), make_robot("RB")
    inside = ask(a, at=t0)
    lease_enter(robot=a, resource=resource("ELEV"), now=t0)
    waiting = ask(b, at=t0)
    lease_sweep(now=t0 + 900 * SECOND)

    with django_capture_on_commit_callbacks(execute=True):
        granted = lease_revoke(lease=inside, by=staff, now=t0 + 1000 * SECOND)

    assert [lease.pk for lease in granted] == [waiting.pk]
    revoked = reloaded(inside)
    assert (revoked.state, revoked.end_cause, revoked.ended_by) == ("revoked", "admin", staff)
    assert holders("ELEV") == ["RB"]
    assert [type for type, _ in board(b)] == ["resource_grant"]
    assert Alert.objects.get().acknowledged_by == staff
    assert lease_revoke(lease=inside, by=staff) is None


@pytest.mark.parametrize(
    ("dropped_state", "next_state", "next_board"),
    [("queued", "queued", "resource_queued"), ("granted", "granted", "resource_grant")],
)
def test_it_drops_an_offline_robot_from_the_queue_and_serves_the_next(
    make_robot, t0, dropped_state, next_state, next_board
):
    a, b, c = make_robot("RA"), make_robot("RB"), make_robot("RC")
    if dropped_state == "queued":  # RA is inside: RB waits in the queue
        ask(a, at=t0)
        lease_enter(robot=a, resource=resource("ELEV"), now=t0)
    dropped = ask(b, at=t0)
    waiting = ask(c, at=t0)
    for robot in (a, c):  # heard from later: still online when RB goes offline
        robot.mark_seen(t0 + 200 * SECOND)
        robot.save(update_fields=Robot.PRESENCE_FIELDS)

    presence_sweep(now=t0 + 300 * SECOND)

    dropped = reloaded(dropped)
    assert (dropped.state, dropped.end_cause) == ("dropped", "robot_offline")
    assert board(b) == []  # its queued message or grant is withdrawn
    assert reloaded(waiting).state == next_state
    assert [type for type, _ in board(c)] == [next_board]


def test_it_lets_an_offline_robot_inside_keep_its_lease(make_robot, t0):
    a = make_robot("RA")
    inside = ask(a, at=t0)
    lease_enter(robot=a, resource=resource("ELEV"), now=t0)

    presence_sweep(now=t0 + 300 * SECOND)

    assert Robot.objects.get(pk=a.pk).presence == "offline"
    assert reloaded(inside).state == "entered"


def test_it_runs_a_sweep_pass_from_the_beat_task(make_robot):
    a = make_robot("RA")
    lease = ask(a, at=timezone.now() - 61 * SECOND)

    tasks.lease_sweep()

    assert reloaded(lease).state == "expired"
