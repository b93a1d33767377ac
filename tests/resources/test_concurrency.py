"""Many robots at once, through gunicorn with two worker processes on PostgreSQL."""

import threading
import time
from collections import Counter

import pytest
from django.db import connections

from boards.models import BoardMessage
from resources.choices import HOLDING_LEASE_STATES
from resources.models import Lease
from tests import factories
from tests.conftest import RobotHttp
from tests.resources.conftest import Bot, acquire, event, holders, lease_of, of_type, release

pytestmark = pytest.mark.slow

DEADLINE = 30.0  # seconds any one scenario may take before it counts as stuck


@pytest.fixture
def make_gunicorn_bot(gunicorn_url, transactional_db, site):
    def make(code: str) -> Bot:
        return Bot(RobotHttp(gunicorn_url, factories.robot_create(site, code)))

    return make


def run_at_once(targets) -> None:
    """Run each target in its own thread, released together by a barrier; re-raise failures."""
    start, failures = threading.Barrier(len(targets)), []

    def run(target):
        try:
            start.wait()
            target()
        except BaseException as exc:
            failures.append(exc)
        finally:
            connections.close_all()

    threads = [threading.Thread(target=run, args=(target,)) for target in targets]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=DEADLINE)
    assert not any(thread.is_alive() for thread in threads), "stuck"
    if failures:
        raise failures[0]


def grants_per_lease() -> Counter:
    grants = BoardMessage.objects.filter(type="resource_grant").values_list("body", flat=True)
    return Counter(body["lease"] for body in grants)


def test_it_grants_one_of_twenty_simultaneous_requests_and_serves_the_rest_in_order(
    make_gunicorn_bot,
):
    bots = [make_gunicorn_bot(f"R{n:02}") for n in range(20)]
    replies = {}

    def ask(bot):
        return lambda: replies.__setitem__(bot.code, bot.acquire("ELEV", to_floor="3F"))

    run_at_once([ask(bot) for bot in bots])

    leases = list(Lease.objects.filter(resource__code="ELEV").select_related("robot"))
    assert len(leases) == 20  # one each: no duplicates
    assert [lease.state for lease in leases] == ["granted"] + ["queued"] * 19  # pk order
    first = replies[leases[0].robot.code]
    assert [m["lease"] for m in of_type(first, "resource_grant")] == [leases[0].public_id]
    positions = [
        [m["position"] for m in of_type(replies[lease.robot.code], "resource_queued")]
        for lease in leases[1:]
    ]
    assert positions == [[n] for n in range(1, 20)]  # in arrival order

    by_code = {bot.code: bot for bot in bots}
    in_order = [by_code[lease.robot.code] for lease in leases]
    for holder, successor in zip(in_order, in_order[1:], strict=False):
        holder.release("ELEV")
        messages = successor.beat()
        assert [m["lease"] for m in of_type(messages, "resource_grant")] == [
            lease_of(successor, "ELEV").public_id
        ]
        assert of_type(messages, "resource_queued") == []  # replaced by the grant
        assert holders("ELEV") == [successor.code]
    assert set(grants_per_lease().values()) == {1}
    assert len(grants_per_lease()) == 20


CAPACITY = {"ELEV": 1, "DOOR-2F": 1, "CORR-3F": 2}


def robot_life(bot: Bot, route: list[str], cycles: int):
    """Ride the route `cycles` times: ask for each resource while leaving the one before (in
    one heartbeat), heartbeat until granted, enter; at the end leave the last one."""

    def wait_for_grant(messages, request_id):
        deadline = time.monotonic() + DEADLINE
        while not [m for m in of_type(messages, "resource_grant") if m["request"] == request_id]:
            assert time.monotonic() < deadline, f"{bot.code} never granted {request_id}"
            messages = bot.beat(acks=[m["id"] for m in messages])
        return messages

    def life():
        inside = None
        for cycle in range(cycles):
            for code in route:
                request_id = f"{bot.code}-{cycle}-{code}"
                ask = acquire(code, id=request_id, to_floor="2F" if code == "ELEV" else None)
                leave = [release(inside)] if inside else []
                messages = wait_for_grant(bot.beat(requests=[*leave, ask]), request_id)
                bot.beat(acks=[m["id"] for m in messages], events=[event("resource_entered", code)])
                inside = code
        bot.beat(requests=[release(inside)], events=[event("resource_released", inside)])

    return life


def hammer(bots: list[Bot], route: list[str], cycles: int = 3) -> dict[str, int]:
    """Run every robot's life at once while watching holders; returns the most seen inside."""
    most, done = dict.fromkeys(route, 0), threading.Event()

    def watch():
        try:
            while not done.is_set():
                for code in route:
                    inside = Lease.objects.filter(
                        resource__code=code, state__in=HOLDING_LEASE_STATES
                    )
                    most[code] = max(most[code], inside.count())
        finally:
            connections.close_all()

    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        run_at_once([robot_life(bot, route, cycles) for bot in bots])
    finally:
        done.set()
        watcher.join(timeout=DEADLINE)
    return most


def assert_all_served_once(route: list[str], leases_each: int) -> None:
    leases = Lease.objects.filter(resource__code__in=route)
    assert leases.count() == leases_each * len(route)
    assert set(leases.values_list("state", flat=True)) == {"released"}
    assert not leases.filter(granted_at__isnull=True).exists()  # nobody entered unasked
    grants = grants_per_lease()
    assert len(grants) == leases.count()
    assert set(grants.values()) == {1}  # every lease granted exactly once


@pytest.mark.parametrize(
    ("route", "cycles"), [(["CORR-3F"], 3), (["DOOR-2F", "CORR-3F", "ELEV"], 2)]
)
def test_it_never_exceeds_capacity_under_concurrent_acquires_and_releases(
    make_gunicorn_bot, route, cycles
):
    bots = [make_gunicorn_bot(f"H{n}") for n in range(6)]

    most = hammer(bots, route, cycles)

    assert all(1 <= most[code] <= CAPACITY[code] for code in route), most
    assert all(holders(code) == [] for code in route)
    assert_all_served_once(route, leases_each=len(bots) * cycles)
