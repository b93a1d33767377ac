"""Pages of the fleet (the thesis' device list and "select a device -> its status"): the fleet
panel with the floor map, a robot's page with the operator's buttons, and acknowledging alerts.

Thin views: reads through selectors, writes through services. The parts a page updates live are
rendered by ui/live/parts.py, for the page and for its re-read after a reconnect.
"""

from dataclasses import dataclass

from django.contrib import messages
from django.db import transaction
from django.http import Http404, HttpResponseBadRequest, JsonResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.urls import reverse
from django.utils.http import url_has_allowed_host_and_scheme
from django.utils.translation import gettext as _
from django.views.decorators.http import require_POST

from building.services import DRIVEN_KINDS, device_hold_doors, device_send_car
from core.access import member_required, operator_required
from resources.leases import lease_revoke
from resources.models import Lease
from robots.alerts import alert_acknowledge
from robots.choices import EmergencySource
from robots.membership import site_required
from robots.models import Alert, AlertKind, Floor, Resource, Robot, Site
from robots.selectors import emergency_active, fleet_snapshot
from scheduling.choices import OperatorActionKind, ResourceActionKind
from scheduling.services import (
    EmergencyRefused,
    MaintenanceRefused,
    emergency_end,
    emergency_start,
    resource_operator_record,
    resource_operator_set_priority,
    resource_operator_set_service,
    robot_action,
    robot_maintenance_end,
    robot_maintenance_start,
)
from ui.drawing import FloorDrawing, floor_drawing, floors_of
from ui.forms import (
    CarSendForm,
    DoorHoldForm,
    FireAlarmForm,
    LiftPriorityForm,
    ResourceServiceForm,
    RobotActionForm,
    RobotMaintenanceForm,
)
from ui.live.parts import fleet_context, resources_context, robot_context
from ui.live.payloads import robot_payload
from ui.selectors import page_site, robot_detail


@member_required
def fleet(request):
    """Every robot of the site, and a floor's map with the robots on it."""
    site, sites = page_site(request)
    robots = fleet_snapshot(site=site)
    floor = request.GET.get("floor") or _busiest_floor(site, robots)
    drawing = floor_drawing(site=site, floor=floor)
    if drawing is None:
        raise Http404(f"no floor {floor!r} at {site.code}")
    context = {
        "page_site": site,
        "sites": sites,
        "floors": floors_of(site=site),
        "drawing": drawing,
        "markers": _markers(drawing, robots),
        # Read only while the site row says one is in force: the page's queries stay constant.
        "fire_alarm": emergency_active(site=site) if site.fire_alarm_since else None,
        **fleet_context(site, robots),
        **resources_context(site),
    }
    return render(request, "robots/fleet.html", context)


@member_required
def robot_page(request, code: str):
    """One robot: its state, plan, tasks, recent events and presence, and operator actions."""
    detail = robot_detail(code=code)
    if detail is None:
        raise Http404(f"no robot {code!r}")
    site_required(request.user, detail.robot.site_id, f"robot {code!r}")
    return render(request, "robots/robot.html", robot_context(detail))


@require_POST
@operator_required
def robot_action_post(request, code: str):
    robot = get_object_or_404(Robot, code=code)
    site_required(request.user, robot.site_id, f"robot {code!r}")
    form = RobotActionForm(request.POST)
    if not form.is_valid():
        return HttpResponseBadRequest("unknown action")
    action = form.cleaned_data["action"]
    robot_action(robot=robot, action=action, by=request.user)
    label = OperatorActionKind(action).label
    messages.success(request, f"{label} sent to {robot.code}.")
    return redirect("robot-page", code=robot.code)


@require_POST
@operator_required
def robot_maintenance_post(request, code: str):
    """An operator takes a robot into maintenance or returns it (the page asked to confirm)."""
    robot = get_object_or_404(Robot, code=code)
    site_required(request.user, robot.site_id, f"robot {code!r}")
    form = RobotMaintenanceForm(request.POST)
    if not form.is_valid():
        return _invalid(form.errors)
    data = form.cleaned_data
    try:
        if data["in_service"]:
            robot_maintenance_end(robot=robot, by=request.user)
            messages.success(request, f"{robot.code} is back in service.")
        else:
            reason, until = data["reason"], data["until"]
            robot_maintenance_start(robot=robot, reason=reason, until=until, by=request.user)
            messages.success(request, f"{robot.code} is in maintenance: {reason}.")
    except MaintenanceRefused as refused:
        if refused.field is not None:
            return _invalid({refused.field: [str(refused)]})
        messages.info(request, str(refused))
    return redirect("robot-page", code=robot.code)


@require_POST
@operator_required
def lease_release_post(request, lease_id: str):
    """An operator's force-release of a stuck lease (the page asked them to confirm: a robot
    may still be inside); the next robot in line is granted at once."""
    pk = Lease.pk_from_public_id(lease_id)
    lease = get_object_or_404(Lease.objects.select_related("robot", "resource__site"), pk=pk)
    site_required(request.user, lease.resource.site_id, f"lease {lease_id!r}")
    granted = lease_revoke(lease=lease, by=request.user)
    where = f"{lease.resource.code} ({lease.robot.code})"
    if granted is None:
        messages.info(request, f"{where} had already been released.")
    else:
        after = ", ".join(g.robot.code for g in granted)
        messages.success(
            request,
            f"{where} force-released. "
            + (f"Now granted to {after}." if after else "Nobody waits."),
        )
    return redirect(f"{reverse('fleet')}?site={lease.resource.site.code}")


@require_POST
@operator_required
def resource_service_post(request, site: str, code: str):
    """An operator takes a resource out of service, or returns it (the page asked to confirm)."""
    resource = _resource_of(request, site, code)
    form = ResourceServiceForm(request.POST)
    if not form.is_valid():
        return _invalid(form.errors)
    in_service, reason = form.cleaned_data["in_service"], form.cleaned_data["reason"]
    done = resource_operator_set_service(
        resource=resource, in_service=in_service, by=request.user, reason=reason
    )
    if done is None:
        messages.info(request, f"{code} already was {'in' if in_service else 'out of'} service.")
    elif in_service:
        messages.success(request, f"{code} is back in service.")
    else:
        messages.success(request, f"{code} is out of service: {reason}.")
    return _back_to_fleet(resource)


@require_POST
@operator_required
def resource_priority_post(request, site: str, code: str):
    """An operator holds a lift for an emergency team, or releases it (the page asked to
    confirm, saying what follows)."""
    resource = _resource_of(request, site, code)
    if not resource.is_elevator:
        raise Http404(f"{code} is not an elevator")
    form = LiftPriorityForm(request.POST)
    if not form.is_valid():
        return _invalid(form.errors)
    on, reason = form.cleaned_data["on"], form.cleaned_data["reason"]
    done = resource_operator_set_priority(resource=resource, on=on, by=request.user, reason=reason)
    if done is None:
        messages.info(request, _("Nothing changed: %(code)s already was so.") % {"code": code})
    elif on:
        messages.success(request, _("%(code)s is held for the emergency team.") % {"code": code})
    else:
        messages.success(request, _("%(code)s is released to the robots.") % {"code": code})
    return _back_to_fleet(resource)


@require_POST
@operator_required
def resource_doors_post(request, site: str, code: str):
    resource = _resource_of(request, site, code, driven=True)
    form = DoorHoldForm(request.POST)
    if not form.is_valid():
        return _invalid(form.errors)
    hold = form.cleaned_data["hold"]
    action = ResourceActionKind.HOLD_DOORS if hold else ResourceActionKind.RELEASE_DOORS
    with transaction.atomic():
        device_hold_doors(resource=resource, hold=hold)
        resource_operator_record(resource=resource, action=action, by=request.user)
    messages.success(request, f"Doors of {code} {'held open' if hold else 'let go'}.")
    return _back_to_fleet(resource)


@require_POST
@operator_required
def resource_car_post(request, site: str, code: str):
    resource = _resource_of(request, site, code, driven=True)
    form = CarSendForm(request.POST)
    floor = None
    if form.is_valid():
        floor = Floor.objects.filter(
            site=resource.site, code=form.cleaned_data["floor"], waypoints__waiting_for=resource
        ).first()
    if not resource.is_elevator or floor is None:
        return _invalid({"floor": [f"{code} does not stop at that floor"]})
    with transaction.atomic():
        device_send_car(resource=resource, floor=floor)
        resource_operator_record(
            resource=resource, action=ResourceActionKind.SEND_CAR, by=request.user, note=floor.code
        )
    messages.success(request, f"Car of {code} sent to {floor.code}.")
    return _back_to_fleet(resource)


def _resource_of(request, site: str, code: str, *, driven=False) -> Resource:
    resource = get_object_or_404(
        Resource.objects.select_related("site"), site__code=site, code=code
    )
    site_required(request.user, resource.site_id, f"resource {code!r}")
    if driven and resource.kind not in DRIVEN_KINDS:
        raise Http404(f"{code} has no lift or door the server drives")
    return resource


def _invalid(detail: dict) -> JsonResponse:
    """400 in the API's error shape, naming each field; nothing was changed."""
    return JsonResponse({"error": "invalid", "detail": detail}, status=400)


def _back_to_fleet(resource: Resource):
    return redirect(f"{reverse('fleet')}?site={resource.site.code}")


@require_POST
@operator_required
def fire_alarm_post(request, site: str):
    """An operator starts the site's fire alarm or gives the all-clear (the page asked them to
    confirm, saying what follows)."""
    found = get_object_or_404(Site, code=site)
    site_required(request.user, found.pk, f"site {site!r}")
    form = FireAlarmForm(request.POST, floors=floors_of(site=found))
    if not form.is_valid():
        return _invalid(form.errors)
    data, via = form.cleaned_data, EmergencySource.OPERATOR
    try:
        if data["start"]:
            emergency_start(
                site=found, floors=data["floors"], reason=data["reason"], via=via, by=request.user
            )
            messages.success(request, "Fire alarm started: robots there are stopping.")
        else:
            emergency_end(site=found, via=via, by=request.user)
            messages.success(request, "All clear: robots resume and held deliveries go out.")
    except EmergencyRefused as refused:
        if refused.field is not None:
            return _invalid({refused.field: [str(refused)]})
        messages.info(request, str(refused))
    return redirect(f"{reverse('fleet')}?site={found.code}")


@require_POST
@operator_required
def alert_acknowledge_post(request, pk: int):
    alert = get_object_or_404(Alert, pk=pk)
    site_required(request.user, alert.site_id, "such alert")
    if alert.kind == AlertKind.FIRE_ALARM:
        messages.info(request, "A fire alarm's notice stays until the all-clear.")
    elif alert.kind == AlertKind.LIFT_PRIORITY:
        messages.info(request, _("A lift priority's notice stays until the lift is released."))
    elif not alert_acknowledge(alert=alert, user=request.user):
        messages.info(request, "Someone had already acknowledged that alert.")
    back = request.POST.get("next", "")
    safe = url_has_allowed_host_and_scheme(back, {request.get_host()}, request.is_secure())
    return redirect(back if safe and back else "deliveries")


# --- Helpers ------------------------------------------------------------------------------------


def _busiest_floor(site: Site, robots: list[Robot]) -> str:
    """The floor most robots are on (ties: the higher); the top floor if none reported."""
    floors = [code for code, _label in floors_of(site=site)]
    counts = dict.fromkeys(floors, 0)
    for wire in map(robot_payload, robots):
        if wire["floor"] in counts:
            counts[wire["floor"]] += 1
    return max(floors, key=lambda code: (counts[code], -floors.index(code)))


@dataclass(frozen=True)
class Marker:
    code: str
    presence: str
    x: float
    y: float


def _markers(drawing: FloorDrawing, robots: list[Robot]) -> list[Marker]:
    markers = []
    for wire in map(robot_payload, robots):
        if wire["floor"] == drawing.floor and wire["x"] is not None and wire["y"] is not None:
            x, y = drawing.place(wire["x"], wire["y"])
            markers.append(Marker(wire["code"], wire["presence"], x, y))
    return markers
