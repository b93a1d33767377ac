"""The receiving unit's view of its station: deliveries on their way, with live ETAs, and an
announcement (and a sound the user can turn off) when a robot is about to arrive or waits to
be unloaded. A nurse can pin it as "my station" (kept in her browser)."""

from django.http import Http404
from django.shortcuts import render

from core.access import member_required
from robots.choices import WaypointKind
from scheduling.selectors import stations_for_site
from ui.live.parts import station_context, station_of
from ui.selectors import page_site


@member_required
def stations(request):
    """The site's stations, each linking to its view."""
    site, sites = page_site(request)
    context = {"page_site": site, "sites": sites, "stations": stations_for_site(site=site)}
    return render(request, "scheduling/stations.html", context)


@member_required
def station_page(request, code: str):
    site, _sites = page_site(request)
    station = station_of(site, code)
    if station is None or station.kind != WaypointKind.STATION:
        raise Http404(f"no station {code!r} at {site.code}")
    return render(request, "scheduling/station.html", station_context(site, station, request.user))
