"""Pages of the fleet (the thesis' device list and "select a device -> its status"): the fleet
panel with the floor map, a robot's page with the operator's buttons, and acknowledging alerts.

Thin views: reads through selectors, writes through services. The parts a page updates live are
rendered by the *_part functions below, for the page and for its re-read after a reconnect
(hospital_delivery.live), from the same partial templates.
"""

from dataclasses import dataclass

from django.contrib import messages
from django.core.exceptions import PermissionDenied
from django.http import Http404, HttpResponseBadRequest
from django.shortcuts import get_object_or_404, redirect, render
from django.template.loader import render_to_string
from django.utils.http import url_has_allowed_host_and_scheme
from django.views.decorators.http import require_POST

from hospital_delivery.access import member_required, operator_required
from hospital_delivery.membership import site_required, sites_of
from robots.alerts import alert_acknowledge
from robots.choices import OperatorActionKind
from robots.forms import RobotActionForm
from robots.models import Alert, Robot, Site
from robots.operator import robot_action
from robots.selectors import (
    FloorDrawing,
    fleet_snapshot,
    floor_drawing,
    floors_of,
    resource_queues,
    robot_detail,
    sites_all,
)
from robots.sitemap import site_map
from robots.wire import robot_wire
from scheduling.selectors import robot_plan, tasks_by_robot


def page_site(request) -> tuple[Site, list[Site]]:
    """The site a page is about (?site=<code>, else the first) and the user's sites, for a
    choice (membership.py)."""
    every = sites_all()
    if not every:
        raise Http404("no site is loaded yet (manage.py load_site FILE)")
    sites = sites_of(request.user, every)
    if not sites:
        raise PermissionDenied("your account belongs to no site: ask an administrator")
    code = request.POST.get("site") or request.GET.get("site")
    if not code:
        return sites[0], sites
    site = next((each for each in sites if each.code == code), None)
    if site is None:
        raise Http404(f"no site {code!r}")
    return site, sites


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
        **_fleet_context(site, robots),
        **_resources_context(site),
    }
    return render(request, "robots/fleet.html", context)


@member_required
def robot_page(request, code: str):
    """One robot: its state, plan, tasks, recent events and presence, and operator actions."""
    detail = robot_detail(code=code)
    if detail is None:
        raise Http404(f"no robot {code!r}")
    site_required(request.user, detail.robot.site_id, f"robot {code!r}")
    return render(request, "robots/robot.html", _robot_context(detail))


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
def alert_acknowledge_post(request, pk: int):
    alert = get_object_or_404(Alert, pk=pk)
    site_required(request.user, alert.site_id, "such alert")
    if not alert_acknowledge(alert=alert, user=request.user):
        messages.info(request, "Someone had already acknowledged that alert.")
    back = request.POST.get("next", "")
    safe = url_has_allowed_host_and_scheme(back, {request.get_host()}, request.is_secure())
    return redirect(back if safe and back else "deliveries")


# --- Parts a page updates live (also for hospital_delivery.live) ------------------------------


def fleet_part(request, site: Site) -> tuple[str, list[dict]]:
    """The fleet table's rows, and every robot's live state (for the map)."""
    robots = fleet_snapshot(site=site)
    context = _fleet_context(site, robots)
    html = render_to_string("robots/_fleet_rows.html", context, request=request)
    return html, [row.wire for row in context["fleet"]]


def resources_part(request, site: Site) -> str:
    context = _resources_context(site)
    return render_to_string("robots/_resources.html", context, request=request)


def robot_part(request, code: str, site: Site) -> tuple[str, dict] | None:
    """The robot page's panels, and the robot's live state (None: no such robot at `site`)."""
    detail = robot_detail(code=code)
    if detail is None or detail.robot.site_id != site.pk:
        return None
    context = _robot_context(detail)
    html = render_to_string("robots/_robot_panels.html", context, request=request)
    return html, context["wire"]


def alerts_part(request) -> str:
    return render_to_string("_alerts.html", {}, request=request)


# --- Helpers ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FleetRow:
    robot: Robot
    wire: dict
    tasks: list


def _fleet_context(site: Site, robots: list[Robot]) -> dict:
    held = tasks_by_robot(robots=robots)
    rows = [FleetRow(robot, robot_wire(robot), held.get(robot.pk, [])) for robot in robots]
    return {"page_site": site, "fleet": rows}


def _resources_context(site: Site) -> dict:
    resources = site_map(site).resources
    queues = resource_queues(site=site)
    return {
        "page_site": site,
        "resources": [(resources[code], queues.get(code, [])) for code in sorted(resources)],
    }


def _robot_context(detail) -> dict:
    robot = detail.robot
    return {
        "page_site": robot.site,
        "robot": robot,
        "wire": robot_wire(robot),
        "detail": detail,
        "plan": robot_plan(robot=robot),
        "tasks": tasks_by_robot(robots=[robot]).get(robot.pk, []),
    }


def _busiest_floor(site: Site, robots: list[Robot]) -> str:
    """The floor most robots are on (ties: the higher); the top floor if none reported."""
    floors = [code for code, _label in floors_of(site=site)]
    counts = dict.fromkeys(floors, 0)
    for wire in map(robot_wire, robots):
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
    for wire in map(robot_wire, robots):
        if wire["floor"] == drawing.floor and wire["x"] is not None and wire["y"] is not None:
            x, y = drawing.place(wire["x"], wire["y"])
            markers.append(Marker(wire["code"], wire["presence"], x, y))
    return markers
