"""The resource controller (protocol v1, "Resources"; the paper's RC, sections 3.1.4 and 4.3).

Elevators, doors and corridors are shared through leases (resources.models.Lease):

    queued --> granted --> entered --> released     (by the robot: release / resource_released)
      |           |-> expired                      (not entered before expires_at: the sweep)
      |-----------|-> dropped                      (robot offline while waiting)
    any live state --> revoked                     (an administrator: lease_revoke)

* One holder per unit of capacity; holders are granted or entered leases. Waiting leases are
  served first-come first-served by arrival at the server: every lease of a resource is created
  and changed with that Resource row locked, so lease pk order is arrival order.
* A resource out of service (resources/availability.py) is granted to nobody: its requests
  queue, and are served in order once it is back in service.
* A robot inside keeps its lease while silent; past the site's hard limit operators are alerted
  and nothing is handed over: only the robot itself or an administrator ends it.

Locks: always the robot row first, then resource rows in pk order. A heartbeat holds its robot's
row when lease_heartbeat_apply runs; sweeps and the admin lock resources only. Messages are
posted in the transaction that changes the lease, also for robots whose rows it does not hold:
robot_lock takes FOR NO KEY UPDATE, which lets the foreign-key check of a board message for
that robot through, so posting never waits on (or deadlocks with) the robot's own heartbeat.
"""

import heapq
from datetime import datetime
from statistics import fmean

from django.db import transaction
from django.db.models import Max
from django.utils import timezone
from django.utils.translation import gettext_noop

from audit.choices import Kind
from audit.services import entry_record
from boards import protocol
from boards.choices import RESOURCE_EVENT_TYPES, EventType, MessageType, RequestType
from boards.models import BoardMessage, RobotEvent, RobotRequest
from boards.services import AppliedHeartbeat, HeartbeatRejected, board_post, board_withdraw
from core import changes
from core.said import Said
from resources.choices import LeaseEndCause, LeaseState
from resources.hooks import lease_changed
from resources.metrics import lease_wait_observe
from resources.models import Lease
from robots.alerts import alert_acknowledge, alert_raise
from robots.mapcache import site_map
from robots.models import Alert, AlertKind, Resource, Robot, Site
from robots.router import SiteMap

GRANT_FIELDS = ["state", "granted_at", "expires_at"]
END_FIELDS = ["state", "end_cause", "ended_at", "ended_by"]
DEFAULT_PASSAGE_SECONDS = 15.0  # typical door or corridor passage before there is any history
RECENT_HOLDS = 20  # completed leases averaged for a resource's typical hold time


# --- Heartbeats (boards.hooks.heartbeat_applied) -----------------------------------------------


def lease_heartbeat_apply(*, applied: AppliedHeartbeat) -> None:
    """Apply one heartbeat's new resource events, then its new acquire/release requests.

    Runs inside the heartbeat's transaction with the robot row locked. A bad request raises
    HeartbeatRejected naming its field ("requests[2].to_floor") before anything is written
    here; the heartbeat's transaction then rolls back, so nothing of it is applied.
    """
    events = [event for event in applied.events if event.type in RESOURCE_EVENT_TYPES]
    if not events and not applied.requests:
        return
    robot, now = applied.robot, applied.now
    _floors_check(applied, site_map(robot.site))
    codes = {item.resource for item in [*events, *applied.requests]}
    resources = _resources_lock(site_id=robot.site_id, codes=codes)
    _leases_check(applied, events, robot=robot, resources=resources)
    for event in events:
        if event.resource in resources:  # else removed from the map since it was validated
            _event_apply(event, robot=robot, resource=resources[event.resource], now=now)
    for request in applied.requests:
        _request_apply(request, robot=robot, resource=resources[request.resource], now=now)


def _floors_check(applied: AppliedHeartbeat, site: SiteMap) -> None:
    """Refuse elevator requests without a served to_floor."""
    errors = {}
    for request in applied.requests:
        if request.type == RequestType.ACQUIRE:
            problem = _to_floor_problem(site, request.resource, request.to_floor)
            if problem:
                errors[_field(applied, request, "to_floor")] = [problem]
    if errors:
        raise HeartbeatRejected(errors)


def _to_floor_problem(site: SiteMap, resource_code: str, to_floor: str | None) -> str | None:
    resource = site.resources.get(resource_code)
    if resource is None or not resource.is_elevator:
        return None  # unknown codes are the serializer's; only elevators take a to_floor
    if not to_floor:
        return f"required to ride elevator {resource_code}"
    if not site.serves_floor(resource_code, to_floor):
        return f"elevator {resource_code} does not stop at {to_floor}"
    return None


def _leases_check(applied, events, *, robot: Robot, resources: dict[str, Resource]) -> None:
    """Refuse requests for resources gone from the map, and releases of a resource the robot
    has no lease on, nor will have by then in this heartbeat (events apply first, then the
    requests in order). A release after its lease ended (released, expired, revoked, dropped)
    is accepted and changes nothing: the robot could not have known."""
    had = _resources_with_leases(robot, applied.requests, resources)
    had |= {event.resource for event in events if event.type == EventType.RESOURCE_ENTERED}
    errors = {}
    for request in applied.requests:
        if request.resource not in resources:
            errors[_field(applied, request, "resource")] = [f"unknown resource {request.resource}"]
        elif request.type == RequestType.ACQUIRE:
            had.add(request.resource)
        elif request.resource not in had:
            problem = f"{robot.code} holds no lease on {request.resource}"
            errors[_field(applied, request, "resource")] = [problem]
    if errors:
        raise HeartbeatRejected(errors)


def _resources_with_leases(robot: Robot, requests, resources: dict[str, Resource]) -> set[str]:
    released = {
        resources[r.resource].pk
        for r in requests
        if r.type == RequestType.RELEASE and r.resource in resources
    }
    if not released:
        return set()
    ids = Lease.objects.filter(robot=robot, resource_id__in=released).values_list(
        "resource_id", flat=True
    )
    codes = {resource.pk: code for code, resource in resources.items()}
    return {codes[pk] for pk in ids}


def _field(applied: AppliedHeartbeat, request: RobotRequest, name: str) -> str:
    return f"requests[{applied.request_index[request.request_id]}].{name}"


def _event_apply(event: RobotEvent, *, robot: Robot, resource: Resource, now) -> None:
    if event.type == EventType.RESOURCE_ENTERED:
        _enter(robot=robot, resource=resource, now=now)
    else:
        _release(robot=robot, resource=resource, cause=LeaseEndCause.RELEASED_EVENT, now=now)


def _request_apply(request: RobotRequest, *, robot: Robot, resource: Resource, now) -> None:
    if request.type == RequestType.ACQUIRE:
        _acquire(
            robot=robot,
            resource=resource,
            request_id=request.request_id,
            to_floor=request.to_floor,
            now=now,
        )
    else:  # a release without a live lease is a repeat: _leases_check let only those through
        _release(robot=robot, resource=resource, cause=LeaseEndCause.RELEASE_REQUEST, now=now)


# --- Services for other code -------------------------------------------------------------------


@transaction.atomic
def lease_revoke(*, lease: Lease, by=None, now=None) -> list[Lease] | None:
    """Force-release a live lease (an administrator) and serve the next in line.

    Returns the leases granted in its place, or None if it had already ended. An open
    hard-limit alert about the lease is acknowledged by the same person.
    """
    now = now or timezone.now()
    resource = _resource_lock(lease.resource_id)
    live = _live(resource)
    target = next((each for each in live if each.pk == lease.pk), None)
    if target is None:
        return None
    before = target.state
    target.end(state=LeaseState.REVOKED, cause=LeaseEndCause.ADMIN, now=now, by=by)
    _save_and_tell(target, resource=resource, fields=END_FIELDS)
    entry_record(
        kind=Kind.LEASE_FORCE_RELEASED,
        obj=target,
        actor=by,
        site_id=resource.site_id,
        object_repr=f"{target.public_id}: {target.robot.code} on {resource.code}",
        changes={"state": [before, target.state]},
    )
    for alert in Alert.objects.open().filter(key=_hard_limit_key(target)):
        alert_acknowledge(alert=alert, user=by)
    return _serve(resource, live, now=now)


@transaction.atomic
def lease_drop_waiting(*, robot: Robot, now: datetime) -> int:
    """Drop the queued and granted-not-entered leases of a robot gone offline; the next in line
    is served. Entered leases stay. Call with the robot row locked (its presence flip)."""
    waiting = Lease.objects.filter(
        robot=robot, state__in=[LeaseState.QUEUED, LeaseState.GRANTED]
    ).values_list("resource_id", flat=True)
    resource_ids = list(waiting)
    if not resource_ids:
        return 0
    resources = _locked_resources().filter(pk__in=resource_ids)
    return sum(_drop(robot=robot, resource=resource, now=now) for resource in resources)


def lease_grants_take_back(*, resource: Resource) -> int:
    """Queue again, each in its place, the robots granted the locked resource and not inside
    yet (a fire alarm: the fire service recalls the cars); each is told `resource_queued`,
    which replaces its grant. Robots inside keep their leases. Returns how many."""
    taken = [lease for lease in _live(resource) if lease.state == LeaseState.GRANTED]
    for lease in taken:
        lease.grant_take_back()
        _save_and_tell(lease, resource=resource, fields=GRANT_FIELDS)
    return len(taken)


def resource_queue(*, resource: Resource) -> list[Lease]:
    """Live leases of `resource` in service order: holders first, then the queue, next first."""
    return list(
        Lease.objects.live().filter(resource=resource).in_queue_order().select_related("robot")
    )


def resource_wait_estimate(*, resource: Resource, now: datetime | None = None) -> float:
    """Seconds a request arriving `now` would wait for its grant: a rough estimate.

    Each unit of capacity frees up when its holder has held it for the typical hold time (the
    mean of recent completed leases, else a ride or passage by the map); then the queue is
    served in order, each taking the typical hold time.
    """
    now = now or timezone.now()
    queue = resource_queue(resource=resource)
    hold = _typical_hold(resource)
    remaining = sorted(max(0.0, hold - _held_for(lease, now)) for lease in queue if lease.holds)
    units = ([0.0] * resource.capacity + remaining)[-resource.capacity :]
    heapq.heapify(units)
    for _ in range(sum(not lease.holds for lease in queue)):
        heapq.heapreplace(units, units[0] + hold)  # the next in line takes the first free unit
    return units[0]


# --- Sweep (Celery beat: resources.tasks.lease_sweep) -------------------------------------------


def lease_sweep(*, now: datetime | None = None) -> dict[str, int]:
    """One pass: expire grants not taken up, alert on silent robots past the hard limit."""
    now = now or timezone.now()
    return {
        "expired": lease_expire_due(now=now),
        "alerted": lease_hard_limit_check(now=now),
    }


def lease_expire_due(*, now: datetime) -> int:
    due = Lease.objects.filter(state=LeaseState.GRANTED, expires_at__lte=now)
    due = due.select_related("robot").order_by("expires_at", "pk")
    return sum(lease_expire(lease=lease, now=now) for lease in due)


@transaction.atomic
def lease_expire(*, lease: Lease, now: datetime) -> bool:
    """Expire one grant not entered by its expires_at and serve the next in line.

    Claimed by a conditional UPDATE: False if the robot entered or released it, or another
    sweeper expired it, since it was read.
    """
    resource = _resource_lock(lease.resource_id)
    claimed = Lease.objects.filter(
        pk=lease.pk, state=LeaseState.GRANTED, expires_at__lte=now
    ).update(state=LeaseState.EXPIRED, end_cause=LeaseEndCause.GRANT_TIMEOUT, ended_at=now)
    if not claimed:
        return False
    lease.end(state=LeaseState.EXPIRED, cause=LeaseEndCause.GRANT_TIMEOUT, now=now)
    _board_sync(lease, resource=resource)
    _publish(lease, resource)
    _serve(resource, _live(resource), now=now)
    return True


def lease_hard_limit_check(*, now: datetime) -> int:
    """Alert operators about robots silent inside a resource past the site's hard limit.

    The lease is kept: the robot may still be inside. One alert per silence (a robot heard
    from again and silent again is reported again). Returns how many alerts were raised.
    """
    inside = Lease.objects.filter(state=LeaseState.ENTERED).select_related(
        "robot", "resource__site"
    )
    due = [
        lease
        for lease in inside
        if lease.hard_limit_alert_due(now, lease.resource.site.lease_hard_limit)
    ]
    return sum(lease_hard_limit_alert(lease=lease, now=now) for lease in due)


@transaction.atomic
def lease_hard_limit_alert(*, lease: Lease, now: datetime) -> bool:
    """Raise the hard-limit alert of one lease read by the sweep, claimed by a conditional
    UPDATE (False if another sweeper got there first; the open alert is shared anyway)."""
    robot, resource, since = lease.robot, lease.resource, lease.silent_since()
    alert_raise(
        site_id=resource.site_id,
        kind=AlertKind.LEASE_HARD_LIMIT,
        key=_hard_limit_key(lease),
        message=Said(
            gettext_noop(
                "%(robot)s has been silent inside %(resource)s since %(since)s and keeps lease "
                "%(lease)s: nobody else is let in. Find the robot; if it has left, force-release "
                "the lease."
            ),
            robot=robot.code,
            resource=resource.code,
            since=f"{timezone.localtime(since):%H:%M:%S}",
            lease=str(lease.public_id),
        ),
        robot=robot,
        resource=resource,
    )
    claimed = Lease.objects.filter(
        pk=lease.pk, state=LeaseState.ENTERED, hard_limit_alerted_at=lease.hard_limit_alerted_at
    ).update(hard_limit_alerted_at=now)
    return bool(claimed)


def _hard_limit_key(lease: Lease) -> str:
    return f"lease-hard-limit:{lease.pk}"


# --- Lease transitions (resource row locked by the caller) -------------------------------------


def _acquire(*, robot: Robot, resource: Resource, request_id: str, to_floor, now) -> Lease:
    live = _live(resource)
    to_floor_id = _floor_id(resource.site, to_floor) if resource.is_elevator else None
    mine = _of_robot(live, robot)
    if mine is not None:
        return _acquire_again(
            mine,
            live,
            robot=robot,
            resource=resource,
            request_id=request_id,
            to_floor_id=to_floor_id,
        )
    _serve(resource, live, now=now)
    lease = Lease(
        resource=resource,
        robot=robot,
        request_id=request_id,
        requested_at=now,
        from_floor_id=robot.floor_id,
        to_floor_id=to_floor_id,
    )
    if _free(resource, live) > 0:
        _grant(lease, resource=resource, now=now)
    lease.save()
    position = sum(each.state == LeaseState.QUEUED for each in live) + 1
    _board_sync(lease, resource=resource, position=position, fresh=True)
    if not resource.grantable:  # queued: the robot hears why, and may go another way
        out_of_service_tell(lease.robot, resource)
    _publish(lease, resource)
    return lease


def _acquire_again(
    lease: Lease, live: list[Lease], *, robot: Robot, resource: Resource, request_id, to_floor_id
) -> Lease:
    """A new acquire from a robot already holding or queued: answer with the lease it has."""
    lease.request_id = request_id
    lease.to_floor_id = to_floor_id or lease.to_floor_id
    lease.save(update_fields=["request_id", "to_floor"])
    if lease.holds:
        _post(lease, type=MessageType.RESOURCE_GRANT, body=_grant_body(lease, resource))
    else:
        body = _queued_body(lease, resource, _position_in(live, lease))
        _post(lease, type=MessageType.RESOURCE_QUEUED, body=body)
    return lease


def _release(*, robot: Robot, resource: Resource, cause: str, now) -> Lease | None:
    live = _live(resource)
    mine = _of_robot(live, robot)
    if mine is None:
        return None
    mine.end(state=LeaseState.RELEASED, cause=cause, now=now)
    _save_and_tell(mine, resource=resource, fields=END_FIELDS)
    _serve(resource, live, now=now)
    return mine


def _enter(*, robot: Robot, resource: Resource, now) -> Lease:
    live = _live(resource)
    mine = _of_robot(live, robot)
    if mine is not None and mine.state == LeaseState.ENTERED:
        return mine
    if mine is None:  # entered without asking: record where it is, holding the resource
        mine = Lease(resource=resource, robot=robot, requested_at=now, from_floor_id=robot.floor_id)
        mine.enter(now=now)
        mine.save()
        _publish(mine, resource)
    else:
        mine.enter(now=now)
        _save_and_tell(mine, resource=resource, fields=["state", "entered_at"])
    if mine.entered_without_grant:
        _alert_entered_without_grant(mine, robot=robot, resource=resource, live=live)
    return mine


def _alert_entered_without_grant(lease, *, robot: Robot, resource: Resource, live) -> None:
    holders = sum(each.holds for each in live if each.pk != lease.pk) + 1
    alert_raise(
        site_id=resource.site_id,
        kind=AlertKind.ENTERED_WITHOUT_GRANT,
        key=f"entered-without-grant:{lease.pk}",
        message=Said(
            gettext_noop(
                "%(robot)s entered %(resource)s without a grant (%(holders)s inside, capacity "
                "%(capacity)s). It counts as a holder until it reports leaving."
            ),
            robot=robot.code,
            resource=resource.code,
            holders=holders,
            capacity=resource.capacity,
        ),
        robot=robot,
        resource=resource,
    )


def _drop(*, robot: Robot, resource: Resource, now) -> int:
    live = _live(resource)
    mine = _of_robot(live, robot)
    if mine is None or mine.state == LeaseState.ENTERED:
        return 0
    mine.end(state=LeaseState.DROPPED, cause=LeaseEndCause.ROBOT_OFFLINE, now=now)
    _save_and_tell(mine, resource=resource, fields=END_FIELDS)
    _serve(resource, live, now=now)
    return 1


def _serve(resource: Resource, live: list[Lease], *, now) -> list[Lease]:
    """Grant waiting leases in arrival order while a unit of capacity is free."""
    waiting = [lease for lease in live if lease.state == LeaseState.QUEUED]
    granted = waiting[: max(_free(resource, live), 0)]
    for lease in granted:
        _grant(lease, resource=resource, now=now)
        _save_and_tell(lease, resource=resource, fields=GRANT_FIELDS)
    return granted


def _grant(lease: Lease, *, resource: Resource, now) -> None:
    now = _not_before_an_end_recorded_after(now, resource=resource)
    lease.grant(now=now, timeout=resource.site.grant_timeout)
    lease_wait_observe(kind=resource.kind, seconds=(now - lease.requested_at).total_seconds())


def _not_before_an_end_recorded_after(now: datetime, *, resource: Resource) -> datetime:
    """`now`, or the latest end recorded after it of a lease of the resource. A transaction
    takes its time before it waits for the resource's lock, so the holder it waited for may
    have ended at a later time than that; a grant recorded before that end would show two
    robots holding one place."""
    later = Lease.objects.filter(resource=resource, ended_at__gt=now).aggregate(Max("ended_at"))
    return later["ended_at__max"] or now


def _save_and_tell(lease: Lease, *, resource: Resource, fields) -> None:
    """Save a lease's new state and make its robot's board show it."""
    lease.save(update_fields=fields)
    _board_sync(lease, resource=resource)
    _publish(lease, resource)


# --- Board messages -----------------------------------------------------------------------------


def _board_sync(
    lease: Lease, *, resource: Resource, position: int | None = None, fresh=False
) -> None:
    """Post or withdraw the robot's messages about `lease` to match its state."""
    if lease.state == LeaseState.QUEUED:
        body = _queued_body(lease, resource, position or _position(lease))
        _post(lease, type=MessageType.RESOURCE_QUEUED, body=body, fresh=fresh)
    elif lease.state == LeaseState.GRANTED:
        body = _grant_body(lease, resource)
        _post(lease, type=MessageType.RESOURCE_GRANT, body=body, fresh=fresh)
    elif lease.state == LeaseState.ENTERED:
        if lease.entered_without_grant:  # jumped the queue: "wait" no longer applies
            _withdraw(lease, _pending(lease).filter(type=MessageType.RESOURCE_QUEUED))
    else:
        _withdraw(lease, _pending(lease))


def _post(lease: Lease, *, type: str, body: dict, fresh=False) -> None:
    # A new lease has no messages yet; otherwise replace one the robot has not acked.
    board_post(robot=lease.robot, type=type, body=body, key=lease.board_key, supersede=not fresh)


def _pending(lease: Lease):
    return BoardMessage.objects.pending().filter(robot_id=lease.robot_id, key=lease.board_key)


def _withdraw(lease: Lease, messages) -> None:
    board_withdraw(messages=messages, reason=f"lease {lease.public_id} {lease.state}")


def _grant_body(lease: Lease, resource: Resource) -> dict:
    to_floor = _floor_code(resource.site, lease.to_floor_id) if resource.is_elevator else None
    return protocol.grant_body(
        request=lease.request_id,
        resource=resource.code,
        lease=lease.public_id,
        expires_at=lease.expires_at or lease.entered_at,
        to_floor=to_floor,
    )


def _queued_body(lease: Lease, resource: Resource, position: int) -> dict:
    return protocol.queued_body(request=lease.request_id, resource=resource.code, position=position)


def out_of_service_tell(robot: Robot, resource: Resource) -> None:
    """Post `robot` the resource's service state (one message per robot and resource: the
    newest replaces one not acked yet). A lift in priority mode is out of service to robots."""
    if resource.grantable:
        type, body = (
            MessageType.RESOURCE_IN_SERVICE,
            protocol.in_service_body(resource=resource.code),
        )
    else:
        type = MessageType.RESOURCE_OUT_OF_SERVICE
        body = protocol.out_of_service_body(
            resource=resource.code,
            since=resource.out_of_service_since or resource.priority_since,
            reason=resource.out_of_service_reason or f"Lift priority: {resource.priority_reason}",
        )
    board_post(robot=robot, type=type, body=body, key=f"service:{resource.pk}", supersede=True)


def _publish(lease: Lease, resource: Resource) -> None:
    site_id = resource.site_id
    changes.changed(kind=changes.LEASE, site_id=site_id, subject=lease, resource=resource)
    lease_changed(lease=lease, resource=resource)


# --- Helpers ------------------------------------------------------------------------------------


def resource_lock(pk: int) -> Resource:
    """The resource row locked FOR UPDATE (with its site read), for other resource services."""
    return _resource_lock(pk)


def resource_serve(*, resource: Resource, now: datetime) -> list[Lease]:
    """Grant the waiting leases of a locked resource while a unit is free."""
    return _serve(resource, _live(resource), now=now)


def lease_board_sync(lease: Lease, *, resource: Resource, fresh=False) -> None:
    """Make the robot's board and the pages show the lease as it now stands (resource row
    locked), for other resource services."""
    _board_sync(lease, resource=resource, fresh=fresh)
    _publish(lease, resource)


def resource_live_leases(resource: Resource) -> list[Lease]:
    """The locked resource's live leases in arrival order."""
    return _live(resource)


def _locked_resources():
    """Resources locked FOR UPDATE in pk order (their site is read, not locked)."""
    return Resource.objects.select_for_update(of=("self",)).select_related("site").order_by("pk")


def _resources_lock(*, site_id: int, codes) -> dict[str, Resource]:
    return {r.code: r for r in _locked_resources().filter(site_id=site_id, code__in=codes)}


def _resource_lock(pk: int) -> Resource:
    return _locked_resources().get(pk=pk)


def _live(resource: Resource) -> list[Lease]:
    """The resource's live leases in arrival order (call with the resource locked)."""
    return list(
        Lease.objects.live().filter(resource=resource).select_related("robot").order_by("pk")
    )


def _of_robot(live: list[Lease], robot: Robot) -> Lease | None:
    return next((lease for lease in live if lease.robot_id == robot.pk), None)


def _free(resource: Resource, live: list[Lease]) -> int:
    if not resource.grantable:
        return 0  # its waiting robots are held in the queue until it is back (or released)
    if resource.is_elevator and resource.site.fire_alarm_since is not None:
        return 0  # the fire service has the cars: queued until the all-clear
    return resource.capacity - sum(lease.holds for lease in live)


def _position_in(live: list[Lease], lease: Lease) -> int:
    return sum(each.state == LeaseState.QUEUED and each.pk < lease.pk for each in live) + 1


def _position(lease: Lease) -> int:
    ahead = Lease.objects.filter(
        resource_id=lease.resource_id, state=LeaseState.QUEUED, pk__lt=lease.pk
    )
    return ahead.count() + 1


def _floor_id(site: Site, code: str | None) -> int | None:
    return site_map(site).floor_ids.get(code) if code else None


def _floor_code(site: Site, floor_id: int | None) -> str | None:
    codes = site_map(site).floor_ids.items()
    return next((code for code, pk in codes if pk == floor_id), None)


def _typical_hold(resource: Resource) -> float:
    recent = (
        Lease.objects.filter(resource=resource, state=LeaseState.RELEASED, granted_at__isnull=False)
        .order_by("-pk")
        .values_list("granted_at", "ended_at")[:RECENT_HOLDS]
    )
    holds = [(ended - granted).total_seconds() for granted, ended in recent]
    if holds:
        return fmean(holds)
    return resource.ride_seconds(0, 1) if resource.is_elevator else DEFAULT_PASSAGE_SECONDS


def _held_for(lease: Lease, now: datetime) -> float:
    return (now - (lease.granted_at or lease.entered_at)).total_seconds()
