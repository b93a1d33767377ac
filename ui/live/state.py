"""The pages' re-read: GET /live/<site>/state.json?parts=schedule,fleet,resources,alerts,robot

A page reads it when its websocket (re)opens, and again after events that need more than
their payload, and replaces the parts it shows. Each part is rendered by the same partial
template the page was rendered with (ui/live/parts.py); robots' live state comes as the same
data the "robot" events carry (ui/live/payloads.py), so one piece of page code applies both.
"""

from django.http import Http404, JsonResponse
from django.shortcuts import get_object_or_404
from django.views.decorators.cache import never_cache

from core.access import member_required
from robots.membership import site_required
from robots.models import Site
from ui.live import parts as live_parts

PARTS = ("schedule", "fleet", "resources", "alerts", "robot", "station")
DEFAULT_PARTS = "schedule,fleet,resources,alerts"  # "robot" needs ?robot=, "station" ?station=


@never_cache
@member_required
def state(request, site: str):
    site = get_object_or_404(Site, code=site)
    site_required(request.user, site.pk, f"site {site.code!r}")
    wanted = request.GET.get("parts", DEFAULT_PARTS).split(",")
    unknown = sorted(set(wanted) - set(PARTS))
    if unknown:
        raise Http404(f"no part {', '.join(unknown)}")
    parts, robots = {}, []
    if "schedule" in wanted:
        parts["schedule"] = live_parts.schedule_part(request, site)
    if "fleet" in wanted:
        parts["fleet"], robots = live_parts.fleet_part(request, site)
    if "resources" in wanted:
        parts["resources"] = live_parts.resources_part(request, site)
    if "alerts" in wanted:
        parts["alerts"] = live_parts.alerts_part(request)
    if "robot" in wanted:
        found = live_parts.robot_part(request, request.GET.get("robot", ""), site)
        if found is None:
            raise Http404("no such robot")
        parts["robot"], wire = found
        robots = [wire, *(each for each in robots if each["code"] != wire["code"])]
    if "station" in wanted:
        parts["station"] = live_parts.station_part(request, site, request.GET.get("station", ""))
        if parts["station"] is None:
            raise Http404("no such station")
    return JsonResponse({"site": site.code, "parts": parts, "robots": robots})
