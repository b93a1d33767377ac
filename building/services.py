"""The building's lifts and doors, driven by the leases on their resources.

    lease granted  (lift) the car is called to the robot's floor, doors held open there
                   (door) the door opens
    lease entered  (lift) the car is sent to the robot's destination floor, doors to open there
    lease ended    the session ends: doors close (unless an operator holds them)

The lift's car stopping with its doors open at the floor its lease's robot waits for or rides
to is told to that robot (`elevator_at_floor`, an addition to the protocol): inside the cabin
a robot cannot see which floor it has reached. A device that reports a fault, or stops
reporting for settings.BUILDING_REPORT_TIMEOUT seconds, takes its resource out of service
(resources/availability.py).

Requests are written here, in the lease's transaction (resource row locked); an adapter sends
them: the simulation's sweep (sim_step) or the MQTT bridge (building/adapters/mqtt.py).
"""

from dataclasses import dataclass
from datetime import datetime, timedelta

from django.conf import settings
from django.db import transaction
from django.utils import timezone

from boards import protocol
from boards.choices import MessageType
from boards.models import BoardMessage
from boards.services import board_post, board_withdraw
from building.adapters.sim import SimState, sim_advance
from building.choices import AdapterKind, DoorState, Motion
from building.hooks import fire_panel_changed
from building.models import Device
from core import changes
from resources.availability import resource_take_out_of_service
from resources.choices import HOLDING_LEASE_STATES, LeaseState
from resources.leases import resource_lock
from resources.models import Lease
from robots.choices import ResourceKind
from robots.mapcache import site_map
from robots.models import Floor, Resource, Site

DRIVEN_KINDS = (ResourceKind.ELEVATOR, ResourceKind.DOOR)
REQUEST_FIELDS = ["session", "requested_floor", "requested_door", "request_seq", "state_since"]


# --- Leases (resources.hooks.lease_changed) -----------------------------------------------------


def device_follow_lease(*, lease: Lease, resource: Resource) -> Device | None:
    """Make the resource's device serve `lease` as it now stands (resource row locked)."""
    if resource.kind not in DRIVEN_KINDS or settings.BUILDING_ADAPTER == "none":
        return None
    if lease.state == LeaseState.QUEUED:
        return None  # nothing to drive until it is granted
    device = _device(resource)
    session, floor_id, door = device.session, device.requested_floor_id, device.requested_door
    if lease.state == LeaseState.GRANTED:
        session, door = lease.public_id, DoorState.OPEN
        floor_id = lease.from_floor_id or floor_id  # called to the robot's floor
    elif lease.state == LeaseState.ENTERED:
        session, door = lease.public_id, DoorState.OPEN
        floor_id = lease.to_floor_id or floor_id  # to the destination, doors to open there
    elif device.session == lease.public_id:  # the lease it served ended
        session, door = "", DoorState.CLOSED
    # The lease's own time of the change: the heartbeat's, or the sweep's (time is driven).
    now = lease.ended_at or lease.entered_at or lease.granted_at or timezone.now()
    _request(device, session=session, floor_id=floor_id, door=door, now=now)
    return device


def _request(device: Device, *, session: str, floor_id, door: str, now: datetime) -> None:
    current = (device.session, device.requested_floor_id, device.requested_door)
    if current == (session, floor_id, door):
        return
    device.session, device.requested_floor_id, device.requested_door = session, floor_id, door
    device.request_seq += 1
    if _at_rest(device):  # a new request starts now, not when the device last moved
        device.state_since = now
    device.save(update_fields=REQUEST_FIELDS)
    _publish(device)


def _at_rest(device: Device) -> bool:
    return device.motion == Motion.STOPPED and device.door != DoorState.MOVING


def devices_ensure(*, site) -> int:
    """A device for each elevator and door of `site` (the demo's set-up: panels from the
    start); returns how many were made."""
    if settings.BUILDING_ADAPTER == "none":
        return 0
    missing = Resource.objects.filter(site=site, kind__in=DRIVEN_KINDS, device__isnull=True)
    return sum(1 for resource in missing if _device(resource))


def _device(resource: Resource) -> Device:
    device = Device.objects.filter(resource=resource).first()
    if device is not None:
        device.resource = resource  # the caller's row, locked: no second read
    else:
        now = timezone.now()
        device = Device.objects.create(
            resource=resource,
            adapter=settings.BUILDING_ADAPTER,
            current_floor_id=_lowest_floor_id(resource) if resource.is_elevator else None,
            reported_at=now,
            state_since=now,
        )
    return device


def _lowest_floor_id(resource: Resource) -> int | None:
    floors = Floor.objects.filter(waypoints__waiting_for=resource).order_by("level")
    return floors.values_list("pk", flat=True).first()


# --- Reports (from the simulation or a real controller) ----------------------------------------


@dataclass(frozen=True)
class Report:
    """What a lift or door says about itself (Open-RMF's LiftState / DoorState)."""

    door: str
    floor: str | None = None  # lifts: the floor code the car is at
    motion: str = Motion.STOPPED
    session: str = ""
    fault: str = ""  # non-empty: the device is out of order (fire, offline, emergency...)


@transaction.atomic
def device_report(*, device: Device, report: Report, now: datetime | None = None) -> Device:
    """Apply one report: store it, tell the lease's robot where the car stopped, and take the
    resource out of service on a fault."""
    now = now or timezone.now()
    resource = resource_lock(device.resource_id)
    device = Device.objects.select_for_update().select_related("resource__site").get(pk=device.pk)
    floor_id = _floor_id(resource, report.floor)
    visible = (device.current_floor_id, device.motion, device.door, device.fault)
    device.current_floor_id = floor_id if report.floor else device.current_floor_id
    device.motion, device.door, device.fault = report.motion, report.door, report.fault[:200]
    device.reported_at = now
    device.save(update_fields=["current_floor", "motion", "door", "fault", "reported_at"])
    if visible != (device.current_floor_id, device.motion, device.door, device.fault):
        _publish(device)
    _announce_stop(device, resource)
    if report.fault and resource.in_service:
        reason = f"{resource.code} reports a fault: {report.fault}"
        resource_take_out_of_service(resource=resource, reason=reason, now=now)
    return device


def _floor_id(resource: Resource, code: str | None) -> int | None:
    if not code:
        return None
    return (
        Floor.objects.filter(site_id=resource.site_id, code=code)
        .values_list("pk", flat=True)
        .first()
    )


def _announce_stop(device: Device, resource: Resource) -> None:
    """Tell the lease's robot, once per stop, that the car is at its floor with doors open."""
    if not resource.is_elevator or not device.session or device.door != DoorState.OPEN:
        return
    if device.motion != Motion.STOPPED or device.current_floor_id != device.requested_floor_id:
        return
    stop = f"{device.session}@{device.current_floor_id}"
    if device.announced == stop:
        return
    lease = Lease.objects.filter(pk=Lease.pk_from_public_id(device.session)).first()
    if lease is None or lease.state not in HOLDING_LEASE_STATES:
        return
    floor = Floor.objects.get(pk=device.current_floor_id).code
    body = protocol.elevator_at_floor_body(
        resource=resource.code, lease=lease.public_id, floor=floor, doors="open"
    )
    key = f"car:{lease.pk}"
    board_post(
        robot=lease.robot, type=MessageType.ELEVATOR_AT_FLOOR, body=body, key=key, supersede=True
    )
    device.announced = stop
    device.save(update_fields=["announced"])


# --- Operators' controls ------------------------------------------------------------------------


@transaction.atomic
def device_hold_doors(*, resource: Resource, hold: bool, now: datetime | None = None) -> Device:
    """An operator holds the doors open (or lets them go back to what the lease asks)."""
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    device = _device(resource)
    if device.held_by_operator != hold:
        device.held_by_operator = hold
        device.request_seq += 1
        if _at_rest(device):
            device.state_since = now
        device.save(update_fields=["held_by_operator", "request_seq", "state_since"])
        _publish(device)
    return device


@transaction.atomic
def device_send_car(*, resource: Resource, floor: Floor, now: datetime | None = None) -> Device:
    """An operator sends the car to `floor` (doors to open there); the lease's session stays."""
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    device = _device(resource)
    _request(device, session=device.session, floor_id=floor.pk, door=DoorState.OPEN, now=now)
    return device


# --- A fire alarm: robots out of the cars (scheduling.hooks.fire_alarm_changed) ---------------


@transaction.atomic
def device_stop_at_next_floor(*, resource: Resource, now: datetime | None = None) -> Floor | None:
    """Stop the lift's car at the next floor it serves in its direction of travel (the floor
    it stands at if it is not moving), doors to open there; the lease's session stays, so its
    robot is told of the stop. Returns that floor; None where the server drives no lift or
    does not know where the car is."""
    if not resource.is_elevator or settings.BUILDING_ADAPTER == "none":
        return None
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    device = _device(resource)
    floor = _next_floor(device)
    if floor is not None:
        _request(device, session=device.session, floor_id=floor.pk, door=DoorState.OPEN, now=now)
    return floor


def _next_floor(device: Device) -> Floor | None:
    here = Floor.objects.filter(pk=device.current_floor_id).first()
    if here is None:
        return None
    served = Floor.objects.filter(waypoints__waiting_for=device.resource).distinct()
    if device.motion == Motion.UP:
        ahead = served.filter(level__gt=here.level).order_by("level")
    elif device.motion == Motion.DOWN:
        ahead = served.filter(level__lt=here.level).order_by("-level")
    else:  # standing (or not saying): the doors open where it is
        return here
    return ahead.first() or here


@transaction.atomic
def elevator_riders_let_out(*, site: Site, reason: str, now: datetime | None = None) -> int:
    """Every car of the site with a robot inside stops at its next floor, and each robot there
    is told to get out and wait (`elevator_exit`): the fire service takes the cars. Its lease
    stays until it reports itself out. Returns how many robots were told."""
    now = now or timezone.now()
    told = 0
    for resource in _elevators(site):
        riders = list(_riders(resource))
        if not riders:
            continue
        floor = device_stop_at_next_floor(resource=resource, now=now)
        for lease in riders:
            _exit_post(lease, resource, floor, reason)
            told += 1
    return told


@transaction.atomic
def elevator_riders_carry_on(*, site: Site, now: datetime | None = None) -> int:
    """The all-clear: a car still carrying a robot (one that did not get out) takes it on to
    its destination, and unheard `elevator_exit` messages are withdrawn. Returns how many."""
    now = now or timezone.now()
    carried = 0
    for resource in _elevators(site):
        for lease in _riders(resource):
            board_withdraw(
                messages=BoardMessage.objects.pending().filter(key=_exit_key(lease)),
                reason="fire alarm over",
                now=now,
            )
            if settings.BUILDING_ADAPTER != "none":
                device = _device(resource)
                floor_id = lease.to_floor_id or device.requested_floor_id
                door = DoorState.OPEN  # at the destination, for the robot to get out
                _request(device, session=lease.public_id, floor_id=floor_id, door=door, now=now)
            carried += 1
    return carried


def _elevators(site: Site):
    pks = Resource.objects.filter(site=site, kind=ResourceKind.ELEVATOR).order_by("pk")
    return (resource_lock(pk) for pk in pks.values_list("pk", flat=True))


def _riders(resource: Resource):
    entered = Lease.objects.filter(resource=resource, state=LeaseState.ENTERED)
    return entered.select_related("robot").order_by("pk")


def _exit_post(lease: Lease, resource: Resource, floor: Floor | None, reason: str) -> None:
    waypoint = None
    if floor is not None:
        waypoint = site_map(resource.site).elevator_stops.get(resource.code, {}).get(floor.code)
    body = protocol.elevator_exit_body(
        resource=resource.code,
        lease=lease.public_id,
        floor=floor.code if floor else None,
        waypoint=waypoint,
        reason=reason,
    )
    board_post(
        robot=lease.robot,
        type=MessageType.ELEVATOR_EXIT,
        body=body,
        key=_exit_key(lease),
        supersede=True,
    )


def _exit_key(lease: Lease) -> str:
    return f"exit:{lease.pk}"


# --- The simulation and the deadlines (Celery beat: building.tasks.building_sweep) ------------


def building_sweep(*, now: datetime | None = None) -> dict[str, int]:
    now = now or timezone.now()
    return {"simulated": sim_sweep(now=now), "silent": silence_sweep(now=now)}


def sim_sweep(*, now: datetime) -> int:
    devices = Device.objects.filter(adapter=AdapterKind.SIM).select_related("resource")
    floors: dict[int, dict[int, tuple[str, int]]] = {}  # per site, read once per sweep
    changed = 0
    for device in devices:
        site_id = device.resource.site_id
        if site_id not in floors:
            floors[site_id] = _floors(site_id)
        changed += sim_step(device=device, now=now, floors=floors[site_id])
    return changed


def sim_step(*, device: Device, now: datetime, floors=None) -> bool:
    """Advance a simulated device to `now` and report its state; True if it changed.

    A device at rest whose robot has been told where the car is only notes that it was heard
    from (one UPDATE, no lock): the sweep runs every second."""
    floors = floors if floors is not None else _floors(device.resource.site_id)
    levels = {pk: level for pk, (_code, level) in floors.items()}
    state = SimState(
        level=levels.get(device.current_floor_id),
        door=device.door,
        motion=device.motion if device.motion != Motion.UNKNOWN else Motion.STOPPED,
        since=device.state_since,
    )
    after = sim_advance(
        state,
        target=levels.get(device.requested_floor_id),
        door_open=device.wants_door_open,
        now=now,
        seconds_per_floor=device.resource.seconds_per_floor,
        speedup=settings.BUILDING_SIM_SPEEDUP,
    )
    if after == state and not _announce_due(device):
        Device.objects.filter(pk=device.pk).update(reported_at=now)
        return False
    # Claimed against the request it was computed for: a new request meanwhile (a lease
    # changed) is simulated on the next pass instead.
    claimed = Device.objects.filter(pk=device.pk, request_seq=device.request_seq)
    if not claimed.update(state_since=after.since):
        return False
    floor = next((code for pk, (code, level) in floors.items() if level == after.level), None)
    report = Report(door=after.door, floor=floor, motion=after.motion, session=device.session)
    device_report(device=device, report=report, now=now)
    return after != state


def _announce_due(device: Device) -> bool:
    """A lift serving a lease whose robot has not been told of the car's current stop."""
    stop = f"{device.session}@{device.current_floor_id}"
    return device.resource.is_elevator and bool(device.session) and device.announced != stop


def _floors(site_id: int) -> dict[int, tuple[str, int]]:
    return {
        pk: (code, level)
        for pk, code, level in Floor.objects.filter(site_id=site_id).values_list(
            "pk", "code", "level"
        )
    }


def silence_sweep(*, now: datetime) -> int:
    """Take out of service the resources whose device has been silent too long."""
    cutoff = now - timedelta(seconds=settings.BUILDING_REPORT_TIMEOUT)
    silent = Device.objects.filter(
        reported_at__lt=cutoff, resource__out_of_service_since__isnull=True
    ).select_related("resource")
    taken = 0
    for device in silent:
        since = timezone.localtime(device.reported_at)
        reason = f"{device.resource.code} has not reported since {since:%H:%M:%S}"
        taken += resource_take_out_of_service(resource=device.resource, reason=reason, now=now)
    return taken


def _publish(device: Device) -> None:
    resource = device.resource
    changes.changed(kind=changes.RESOURCE, site_id=resource.site_id, subject=resource)


# --- The fire panel -----------------------------------------------------------------------------


@transaction.atomic
def fire_panel_report(*, site: Site, alarm: bool, floors: list[str], reason: str) -> None:
    """Apply a fire panel's state: its receivers start the site's fire alarm on `floors`, or
    end the one the panel started (scheduling.services.emergency)."""
    fire_panel_changed(site=site, alarm=alarm, floors=floors, reason=reason)
