"""The parts of the pages that update live, one function each: rendered by the same partial
template when the page is rendered (ui/deliveries.py, ui/fleet.py) and when it re-reads them
after a reconnect or an event (ui/live/state.py).
"""

from dataclasses import dataclass, replace

from django.template.loader import render_to_string
from django.utils import timezone

from building.selectors import device_panels
from core.access import can_cancel
from resources.selectors import resource_queues, resource_waits
from robots.mapcache import site_map
from robots.models import Resource, Robot, Site, Waypoint
from robots.selectors import fleet_snapshot
from scheduling.models import Task
from scheduling.selectors import robot_plan, schedule_for_site, station_incoming, tasks_by_robot
from ui.live.payloads import robot_payload
from ui.selectors import pin_for_station, robot_detail, user_unit_ids


def schedule_part(request, site: Site) -> str:
    context = schedule_context(request, site)
    return render_to_string("scheduling/_schedule_rows.html", context, request=request)


def fleet_part(request, site: Site) -> tuple[str, list[dict]]:
    """The fleet table's rows, and every robot's live state (for the map)."""
    robots = fleet_snapshot(site=site)
    context = fleet_context(site, robots)
    html = render_to_string("robots/_fleet_rows.html", context, request=request)
    return html, [row.wire for row in context["fleet"]]


def resources_part(request, site: Site) -> str:
    context = resources_context(site)
    return render_to_string("robots/_resources.html", context, request=request)


def robot_part(request, code: str, site: Site) -> tuple[str, dict] | None:
    """The robot page's panels, and the robot's live state (None: no such robot at `site`)."""
    detail = robot_detail(code=code)
    if detail is None or detail.robot.site_id != site.pk:
        return None
    context = robot_context(detail)
    html = render_to_string("robots/_robot_panels.html", context, request=request)
    return html, context["wire"]


def station_part(request, site: Site, code: str) -> str | None:
    station = station_of(site, code)
    if station is None:
        return None
    context = station_context(site, station, request.user)
    return render_to_string("scheduling/_station_rows.html", context, request=request)


def alerts_part(request) -> str:
    return render_to_string("_alerts.html", {}, request=request)


# --- The parts' contexts -------------------------------------------------------------------------


def schedule_context(request, site: Site) -> dict:
    rows = schedule_for_site(site=site, now=timezone.now())
    cancellable = {row.task.code for row in rows if user_may_cancel(request.user, row.task)}
    return {"page_site": site, "schedule": rows, "cancellable": cancellable}


def station_of(site: Site, code: str) -> Waypoint | None:
    return Waypoint.objects.filter(site=site, code=code).first()


def station_context(site: Site, station: Waypoint, user) -> dict:
    """The deliveries on their way to the station; a secure one's PIN only for the receiving
    unit's staff and its requester (ui.selectors.pin_for_station), and the PINs their
    requesters re-sent as notices."""
    now = timezone.now()
    unit_staff = station.pk in user_unit_ids(user, site)
    rows = [
        replace(row, pin=pin_for_station(row.task, user, unit_staff=unit_staff))
        if row.task.secure
        else row
        for row in station_incoming(site=site, station=station, now=now)
    ]
    resent = [row for row in rows if row.task.secure and row.task.pin_resent_at]
    return {
        "page_site": site,
        "station": station,
        "incoming": rows,
        "resent": resent,
        "unit_staff": unit_staff,
        "now": now,
    }


def user_may_cancel(user, task: Task) -> bool:
    return task.is_cancellable and can_cancel(user, task)


@dataclass(frozen=True)
class FleetRow:
    robot: Robot
    wire: dict
    tasks: list


def fleet_context(site: Site, robots: list[Robot]) -> dict:
    held = tasks_by_robot(robots=robots)
    rows = [FleetRow(robot, robot_payload(robot), held.get(robot.pk, [])) for robot in robots]
    return {"page_site": site, "fleet": rows}


def resources_context(site: Site) -> dict:
    resources = site_map(site).resources
    queues = resource_queues(site=site)
    waits = resource_waits(site=site, now=timezone.now())
    service = {r.code: r for r in Resource.objects.filter(site=site)}
    panels = device_panels(site=site)
    return {
        "page_site": site,
        "resources": [
            ResourceRow(
                resources[code],
                queues.get(code, []),
                waits.get(code),
                service.get(code),
                panels.get(code),
            )
            for code in sorted(resources)
        ],
    }


@dataclass(frozen=True)
class ResourceRow:
    resource: object  # robots.router.MapResource
    leases: list
    wait: float | None
    service: Resource | None  # its row: in service or not, since when, why
    panel: object | None  # building.selectors.DevicePanel: its lift or door, if driven


def robot_context(detail) -> dict:
    robot = detail.robot
    return {
        "page_site": robot.site,
        "robot": robot,
        "wire": robot_payload(robot),
        "detail": detail,
        "plan": robot_plan(robot=robot),
        "tasks": tasks_by_robot(robots=[robot]).get(robot.pk, []),
    }
