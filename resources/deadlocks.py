"""Deadlocks among leases: robots that hold resources and wait for each other's.

A robot may hold one resource while it waits for another (it asks for the lift while its grant
for the door is still unused, or from inside a corridor for the door at its end), so waits can
form a cycle: R1 holds DOOR and waits for ELEV, R2 holds ELEV and waits for DOOR. The lease
sweep looks for such cycles in the wait-for graph (a queued robot waits for every holder of its
resource) and breaks each by one rule:

* the robot of the cycle whose hold is a grant it has not used (not inside yet), the most
  recently granted if several, **yields**: its grant is taken back and it queues again at the
  end of the line (a `resource_queued` for the same request, which takes a grant back); the
  resource goes to the next robot in line, and the cycle is gone (should that robot close a
  new one, the same sweep breaks it too);
* a cycle whose holders are all inside their resources cannot be broken by the server (it
  empties no car or corridor): operators are alerted, once per cycle, to move a robot out and
  force-release its lease.

Either way operators are alerted, naming the robots and resources.
"""

from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime

from django.db import transaction
from django.utils import timezone
from django.utils.translation import gettext_noop

from core.said import Said
from resources.choices import HOLDING_LEASE_STATES, LIVE_LEASE_STATES, LeaseEndCause, LeaseState
from resources.leases import lease_board_sync, resource_lock, resource_serve
from resources.models import Lease
from robots.alerts import alert_raise
from robots.models import AlertKind


@dataclass(frozen=True)
class Hold:
    """One live lease as the wait-for graph sees it."""

    lease: int
    robot: int
    resource: int
    state: str


def wait_cycles(holds: Iterable[Hold]) -> list[list[Hold]]:
    """The cycles of the wait-for graph, each as the holds that close it (one per robot: the
    hold another robot of the cycle waits for), each cycle once, in a stable order."""
    holds = list(holds)
    holders: dict[int, list[Hold]] = {}
    for hold in holds:
        if hold.state in HOLDING_LEASE_STATES:
            holders.setdefault(hold.resource, []).append(hold)
    waits: dict[int, list[Hold]] = {}  # robot -> the holds it waits behind
    for hold in holds:
        if hold.state == LeaseState.QUEUED:
            behind = [h for h in holders.get(hold.resource, []) if h.robot != hold.robot]
            waits.setdefault(hold.robot, []).extend(behind)
    cycles, seen = [], set()
    for start in sorted(waits):
        cycle = _cycle_from(start, waits)
        key = frozenset(hold.lease for hold in cycle)
        if cycle and key not in seen:
            seen.add(key)
            cycles.append(cycle)
    return cycles


def _cycle_from(start: int, waits: dict[int, list[Hold]]) -> list[Hold]:
    """A cycle through `start` (depth first, smallest lease first), else []."""
    path: list[Hold] = []
    visited: set[int] = set()

    def visit(robot: int) -> bool:
        for hold in sorted(waits.get(robot, []), key=lambda h: h.lease):
            path.append(hold)
            if hold.robot == start:
                return True
            if hold.robot not in visited:
                visited.add(hold.robot)
                if visit(hold.robot):
                    return True
            path.pop()
        return False

    return list(path) if visit(start) else []


def lease_deadlock_sweep(*, now: datetime | None = None) -> int:
    """Break the wait-for cycles of every site; returns how many cycles were found.

    A yielded resource goes to the next robot in line, which may close a new cycle with the
    same holder (it waits for what that holder keeps): the sweep looks again until it finds
    no cycle it has not seen. Each yield sends a robot to the end of its line, so the robot
    whose grant ends the cycles reaches the front within a line's length of yields; the rounds
    are bounded by the live leases all the same, and the next sweep goes on from there.
    """
    now = now or timezone.now()
    seen: set[frozenset[int]] = set()
    holds_by_site = _live_holds_by_site()
    rounds = sum(len(holds) for holds in holds_by_site.values()) + 1
    for _round in range(rounds):
        cycles = [
            cycle
            for holds in holds_by_site.values()
            for cycle in wait_cycles(holds)
            if _key(cycle) not in seen
        ]
        if not cycles:
            break
        for cycle in cycles:
            seen.add(_key(cycle))
            lease_deadlock_break(cycle=cycle, now=now)
        holds_by_site = _live_holds_by_site()
    return len(seen)


def _live_holds_by_site() -> dict[int, list[Hold]]:
    live = Lease.objects.filter(state__in=LIVE_LEASE_STATES).order_by()
    rows = live.values_list("pk", "robot_id", "resource_id", "state", "resource__site_id")
    by_site: dict[int, list[Hold]] = {}
    for pk, robot, resource, state, site in rows:
        by_site.setdefault(site, []).append(Hold(pk, robot, resource, state))
    return by_site


def _key(cycle: list[Hold]) -> frozenset[int]:
    return frozenset(hold.lease for hold in cycle)


@transaction.atomic
def lease_deadlock_break(*, cycle: list[Hold], now: datetime) -> Lease | None:
    """Break one cycle by its rule (the module's docstring); returns the lease that yielded,
    None if none could (all inside) or the cycle has gone meanwhile."""
    for resource_id in sorted({hold.resource for hold in cycle}):  # in pk order, as everywhere
        resource_lock(resource_id)
    current = {
        lease.pk: lease
        for lease in Lease.objects.filter(pk__in=[h.lease for h in cycle]).select_related(
            "robot", "resource__site"
        )
    }
    if any(current.get(h.lease) is None or current[h.lease].state != h.state for h in cycle):
        return None  # it moved on since it was read: the next sweep looks again
    unused = [current[h.lease] for h in cycle if h.state == LeaseState.GRANTED]
    yielded = max(unused, key=lambda lease: (lease.granted_at, lease.pk)) if unused else None
    if yielded is not None:
        _yield(yielded, now)
    _alert(cycle, current, yielded)
    return yielded


def _yield(lease: Lease, now: datetime) -> Lease:
    """End the unused grant and queue the robot again, last, for the same request."""
    resource, request_id = lease.resource, lease.request_id
    lease.end(state=LeaseState.REVOKED, cause=LeaseEndCause.DEADLOCK, now=now)
    lease.request_id = ""  # the request is answered by the new lease now (one lease each)
    lease.save(update_fields=["state", "end_cause", "ended_at", "ended_by", "request_id"])
    again = Lease.objects.create(
        robot=lease.robot,
        resource=resource,
        request_id=request_id,
        requested_at=now,
        from_floor_id=lease.from_floor_id,
        to_floor_id=lease.to_floor_id,
    )
    lease_board_sync(lease, resource=resource)
    lease_board_sync(again, resource=resource, fresh=True)
    resource_serve(resource=resource, now=now)
    return again


def _alert(cycle: list[Hold], current: dict[int, Lease], yielded: Lease | None) -> None:
    leases = [current[hold.lease] for hold in cycle]
    who = ", ".join(f"{lease.robot.code} → {lease.resource.code}" for lease in leases)
    if yielded is not None:
        outcome = Said(
            gettext_noop(
                "%(robot)s gave up its unused grant of %(resource)s and waits again, last in line."
            ),
            robot=yielded.robot.code,
            resource=yielded.resource.code,
        )
    else:
        outcome = Said(
            gettext_noop(
                "Every one of them is inside: move one out and force-release its lease on the "
                "fleet page."
            )
        )
    first = leases[0]
    alert_raise(
        site_id=first.resource.site_id,
        kind=AlertKind.LEASE_DEADLOCK,
        key="lease-deadlock:" + ",".join(str(h.lease) for h in sorted(cycle, key=_lease_of)),
        message=Said(
            gettext_noop("Robots waiting for each other's resources (%(who)s). %(outcome)s"),
            who=who,
            outcome=outcome,
        ),
        robot=first.robot,
    )


def _lease_of(hold: Hold) -> int:
    return hold.lease
