"""An in-memory, read-only picture of one site's map, cached per process.

The heartbeat validates codes against it and the router searches it, so neither queries the
map on the hot path. A cached map is keyed by (site id, map_version, availability_version):
every load of a site file bumps map_version, every resource taken out of or returned to
service availability_version, so a process notices either on the next robot row it reads.
"""

from threading import Lock

from robots.models import Edge, Floor, Resource, ResourceWaypoint, Site, Waypoint
from robots.router import (
    MapEdge,
    MapFloor,
    MapResource,
    MapWaypoint,
    Router,
    SiteMap,
    names_tuple,
    site_map_build,
)

_cache: dict[int, SiteMap] = {}
_routers: dict[int, Router] = {}
_by_id: dict[int, tuple[SiteMap, dict[int, str], dict[int, str]]] = {}
_cache_lock = Lock()


def site_map(site: Site) -> SiteMap:
    """The map of `site` as of its map_version; loads it at most once per version per process."""
    cached = _cache.get(site.pk)
    if cached is not None and _current(cached, site):
        return cached
    with _cache_lock:
        cached = _cache.get(site.pk)
        if cached is None or not _current(cached, site):
            cached = _cache[site.pk] = _load(site)
    return cached


def _current(cached: SiteMap, site: Site) -> bool:
    versions = (site.map_version, site.availability_version)
    return (cached.map_version, cached.availability_version) == versions


def router_for(site: Site) -> Router:
    """The Router of `site`'s current map, shared per process so its searches are reused."""
    current = site_map(site)
    router = _routers.get(site.pk)
    if router is None or router.site_map is not current:
        router = _routers[site.pk] = Router(current)
    return router


def waypoint_by_id(site: Site, waypoint_id: int | None) -> MapWaypoint | None:
    """The current map's waypoint with this id (None for None, or one gone from the map)."""
    current, waypoints, _floors = _ids(site)
    code = waypoints.get(waypoint_id)
    return current.waypoints[code] if code else None


def floor_code_by_id(site: Site, floor_id: int | None) -> str | None:
    return _ids(site)[2].get(floor_id)


def _ids(site: Site) -> tuple[SiteMap, dict[int, str], dict[int, str]]:
    """The current map with its waypoint and floor codes by id, built once per map."""
    current = site_map(site)
    cached = _by_id.get(site.pk)
    if cached is None or cached[0] is not current:
        waypoints = {wp.id: wp.code for wp in current.waypoints.values()}
        floors = {pk: code for code, pk in current.floor_ids.items()}
        cached = _by_id[site.pk] = (current, waypoints, floors)
    return cached


def _load(site: Site) -> SiteMap:
    floors = [
        MapFloor(id=f.id, code=f.code, level=f.level, name=f.name, names=names_tuple(f.names))
        for f in Floor.objects.filter(site=site)
    ]
    waypoints = _waypoints(site, {f.id: f for f in floors})
    codes_by_id = {wp.id: wp.code for wp in waypoints}
    return site_map_build(
        site_id=site.pk,
        map_version=site.map_version,
        robot_speed=site.robot_speed,
        floors=floors,
        waypoints=waypoints,
        edges=_edges(site, codes_by_id),
        resources=_resources(site, codes_by_id),
        availability_version=site.availability_version,
    )


def _waypoints(site: Site, floors_by_id: dict[int, MapFloor]) -> list[MapWaypoint]:
    return [
        MapWaypoint(
            id=wp.id,
            code=wp.code,
            name=wp.name,
            kind=wp.kind,
            floor=floors_by_id[wp.floor_id].code,
            level=floors_by_id[wp.floor_id].level,
            x=wp.x,
            y=wp.y,
            names=names_tuple(wp.names),
        )
        for wp in Waypoint.objects.filter(site=site)
    ]


def _edges(site: Site, codes_by_id: dict[int, str]) -> list[MapEdge]:
    resource_codes = dict(Resource.objects.filter(site=site).values_list("id", "code"))
    return [
        MapEdge(
            source=codes_by_id[e.source_id],
            target=codes_by_id[e.target_id],
            length=e.length,
            oneway=e.oneway,
            guarded_by=resource_codes.get(e.guarded_by_id),
        )
        for e in Edge.objects.filter(site=site).order_by("id")
    ]


def _resources(site: Site, codes_by_id: dict[int, str]) -> list[MapResource]:
    stops: dict[int, list[str]] = {}
    for resource_id, waypoint_id in ResourceWaypoint.objects.filter(
        resource__site=site
    ).values_list("resource_id", "waypoint_id"):
        stops.setdefault(resource_id, []).append(codes_by_id[waypoint_id])
    return [
        MapResource(
            id=r.id,
            code=r.code,
            name=r.name,
            kind=r.kind,
            capacity=r.capacity,
            seconds_per_floor=r.seconds_per_floor,
            overhead_seconds=r.overhead_seconds,
            waypoints=tuple(sorted(stops.get(r.id, []))),
            names=names_tuple(r.names),
            # A lift in priority mode is routed round like one out of service.
            out_of_service=r.out_of_service_since is not None or r.priority_since is not None,
        )
        for r in Resource.objects.filter(site=site)
    ]


def site_map_forget(site_id: int) -> None:
    """Drop what this process cached of a site: a map read inside a transaction that then
    rolled back (a refused publication) must not pass for the next map of the same version."""
    with _cache_lock:
        _cache.pop(site_id, None)
        _routers.pop(site_id, None)
        _by_id.pop(site_id, None)
