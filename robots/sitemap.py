"""An in-memory, read-only picture of one site's map, cached per process.

The heartbeat validates codes against it and the router searches it, so neither queries the
map on the hot path. A cached map is keyed by (site id, map_version); every load of a site
file bumps map_version, so a process notices a new map on the next robot row it reads.
"""

from threading import Lock

from robots.graph import MapEdge, MapResource, MapWaypoint, SiteMap
from robots.models import Edge, Floor, Resource, ResourceWaypoint, Site, Waypoint

_cache: dict[int, SiteMap] = {}
_cache_lock = Lock()


def site_map(site: Site) -> SiteMap:
    """The map of `site` as of its map_version; loads it at most once per version per process."""
    cached = _cache.get(site.pk)
    if cached is not None and cached.map_version == site.map_version:
        return cached
    with _cache_lock:
        cached = _cache.get(site.pk)
        if cached is None or cached.map_version != site.map_version:
            cached = _cache[site.pk] = _load(site)
    return cached


def _load(site: Site) -> SiteMap:
    floors = {f.code: (f.id, f.level) for f in Floor.objects.filter(site=site)}
    floor_codes_by_id = {fid: code for code, (fid, _level) in floors.items()}
    waypoints = {
        wp.code: MapWaypoint(
            id=wp.id,
            code=wp.code,
            name=wp.name,
            kind=wp.kind,
            floor=floor_codes_by_id[wp.floor_id],
            level=floors[floor_codes_by_id[wp.floor_id]][1],
            x=wp.x,
            y=wp.y,
        )
        for wp in Waypoint.objects.filter(site=site)
    }
    codes_by_id = {wp.id: wp.code for wp in waypoints.values()}
    resource_codes = dict(Resource.objects.filter(site=site).values_list("id", "code"))
    edges = tuple(
        MapEdge(
            source=codes_by_id[e.source_id],
            target=codes_by_id[e.target_id],
            length=e.length,
            oneway=e.oneway,
            guarded_by=resource_codes.get(e.guarded_by_id),
        )
        for e in Edge.objects.filter(site=site).order_by("id")
    )
    stops: dict[int, list[str]] = {}
    for resource_id, waypoint_id in ResourceWaypoint.objects.filter(
        resource__site=site
    ).values_list("resource_id", "waypoint_id"):
        stops.setdefault(resource_id, []).append(codes_by_id[waypoint_id])
    resources = {
        r.code: MapResource(
            id=r.id,
            code=r.code,
            name=r.name,
            kind=r.kind,
            capacity=r.capacity,
            seconds_per_floor=r.seconds_per_floor,
            overhead_seconds=r.overhead_seconds,
            waypoints=tuple(sorted(stops.get(r.id, []))),
        )
        for r in Resource.objects.filter(site=site)
    }
    elevator_stops = {
        r.code: {waypoints[wp].floor: wp for wp in r.waypoints}
        for r in resources.values()
        if r.is_elevator
    }
    return SiteMap(
        site_id=site.pk,
        map_version=site.map_version,
        robot_speed=site.robot_speed,
        floors={code: level for code, (_fid, level) in floors.items()},
        floor_ids={code: fid for code, (fid, _level) in floors.items()},
        waypoints=waypoints,
        edges=edges,
        resources=resources,
        elevator_stops=elevator_stops,
    )
