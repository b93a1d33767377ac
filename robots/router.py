"""The site graph and travel times, as pure Python (no Django), so the scheduler's allocator,
the robot-side simulator and tests can all use it.

A SiteMap is built either from the database (robots/mapcache.py) or from a parsed, validated
site file (site_map_from_file); both go through site_map_build. A Router answers travel times
and legs on one SiteMap.
"""

import heapq
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

ELEVATOR = "elevator"
STATION = "station"
DOCK = "dock"
DEFAULT_ROBOT_SPEED = 1.0  # metres per second; Site.robot_speed's default


@dataclass(frozen=True)
class MapFloor:
    id: int
    code: str
    level: int
    name: str = ""
    names: tuple[tuple[str, str], ...] = ()  # per language (robots/names.py)


@dataclass(frozen=True)
class MapWaypoint:
    id: int
    code: str
    name: str
    kind: str
    floor: str
    level: int
    x: float
    y: float
    names: tuple[tuple[str, str], ...] = ()  # per language (robots/names.py)

    @property
    def label(self) -> str:
        return self.name or self.code


@dataclass(frozen=True)
class MapEdge:
    source: str
    target: str
    length: float
    oneway: bool
    guarded_by: str | None


@dataclass(frozen=True)
class MapResource:
    id: int
    code: str
    name: str
    kind: str
    capacity: int
    seconds_per_floor: float
    overhead_seconds: float
    waypoints: tuple[str, ...]  # waiting waypoints; for an elevator, one per floor served
    out_of_service: bool = False  # routes avoid it where another way exists (Router)
    names: tuple[tuple[str, str], ...] = ()  # per language (robots/names.py)

    @property
    def is_elevator(self) -> bool:
        return self.kind == ELEVATOR


@dataclass(frozen=True)
class SiteMap:
    site_id: int
    map_version: int
    robot_speed: float
    floors: dict[str, int]  # floor code -> level
    floor_ids: dict[str, int]
    waypoints: dict[str, MapWaypoint]
    edges: tuple[MapEdge, ...]
    resources: dict[str, MapResource]
    # elevator code -> floor code -> its waiting waypoint there
    elevator_stops: dict[str, dict[str, str]] = field(default_factory=dict)
    floor_names: dict[str, str] = field(default_factory=dict)
    availability_version: int = 0  # with map_version, what a cached map is keyed by
    floor_names_by_language: dict[str, tuple[tuple[str, str], ...]] = field(default_factory=dict)

    @property
    def out_of_service(self) -> frozenset[str]:
        return frozenset(code for code, r in self.resources.items() if r.out_of_service)

    def serves_floor(self, resource_code: str, floor_code: str) -> bool:
        return floor_code in self.elevator_stops.get(resource_code, {})

    def codes_of_kind(self, *kinds: str) -> list[str]:
        return [code for code, wp in self.waypoints.items() if wp.kind in kinds]


def site_map_build(
    *,
    site_id: int,
    map_version: int,
    robot_speed: float,
    floors: Iterable[MapFloor],
    waypoints: Iterable[MapWaypoint],
    edges: Iterable[MapEdge],
    resources: Iterable[MapResource],
    availability_version: int = 0,
) -> SiteMap:
    """A SiteMap from its parts, wherever they were read from."""
    floors = list(floors)
    waypoints_by_code = {wp.code: wp for wp in waypoints}
    resources_by_code = {r.code: r for r in resources}
    return SiteMap(
        site_id=site_id,
        map_version=map_version,
        robot_speed=robot_speed,
        floors={f.code: f.level for f in floors},
        floor_ids={f.code: f.id for f in floors},
        waypoints=waypoints_by_code,
        edges=tuple(edges),
        resources=resources_by_code,
        elevator_stops=_elevator_stops(resources_by_code.values(), waypoints_by_code),
        floor_names={f.code: f.name for f in floors},
        availability_version=availability_version,
        floor_names_by_language={f.code: f.names for f in floors},
    )


def _elevator_stops(
    resources: Iterable[MapResource], waypoints: Mapping[str, MapWaypoint]
) -> dict[str, dict[str, str]]:
    return {
        r.code: {waypoints[wp].floor: wp for wp in r.waypoints if wp in waypoints}
        for r in resources
        if r.is_elevator
    }


# --- Site files (the structure of robot-protocol.md "Site description file") -----------------


def file_edge_ends(raw) -> tuple[str, str, float | None, bool]:
    """(from, to, length or None, oneway) of an edge written as [A, B] or {from, to, ...}."""
    if isinstance(raw, list):
        return raw[0], raw[1], None, False
    return raw["from"], raw["to"], raw.get("length"), bool(raw.get("oneway", False))


def edge_index(site_map: SiteMap) -> dict[tuple[str, str], MapEdge]:
    """Each edge by its (from, to) waypoint codes, a two-way edge under both directions."""
    index = {}
    for edge in site_map.edges:
        index[(edge.source, edge.target)] = edge
        if not edge.oneway:
            index[(edge.target, edge.source)] = edge
    return index


def straight_line(a: MapWaypoint, b: MapWaypoint) -> float:
    return math.dist((a.x, a.y), (b.x, b.y))


def site_map_from_file(data: dict, *, site_id: int = 0, map_version: int = 0) -> SiteMap:
    """The SiteMap a valid site file describes; ids are synthetic (1, 2, ... in file order)."""
    floors = [
        MapFloor(
            id=n,
            code=f["code"],
            level=f["level"],
            name=f.get("name", ""),
            names=names_tuple(f.get("names")),
        )
        for n, f in enumerate(data["floors"], start=1)
    ]
    waypoints = _file_waypoints(data)
    guards = _file_guards(data.get("resources", []))
    return site_map_build(
        site_id=site_id,
        map_version=map_version,
        robot_speed=float(data.get("robot_speed", DEFAULT_ROBOT_SPEED)),
        floors=floors,
        waypoints=waypoints.values(),
        edges=_file_edges(data, waypoints, guards),
        resources=_file_resources(data.get("resources", [])),
    )


def _file_waypoints(data: dict) -> dict[str, MapWaypoint]:
    raw = [(floor, wp) for floor in data["floors"] for wp in floor["waypoints"]]
    return {
        wp["code"]: MapWaypoint(
            id=n,
            code=wp["code"],
            name=wp.get("name", ""),
            kind=wp.get("kind", "plain"),
            floor=floor["code"],
            level=floor["level"],
            x=float(wp["x"]),
            y=float(wp["y"]),
            names=names_tuple(wp.get("names")),
        )
        for n, (floor, wp) in enumerate(raw, start=1)
    }


def _file_guards(resources: list[dict]) -> dict[tuple[str, str], str]:
    return {
        (a, b): resource["code"] for resource in resources for a, b in resource.get("guards", [])
    }


def _file_edges(
    data: dict, waypoints: Mapping[str, MapWaypoint], guards: Mapping[tuple[str, str], str]
) -> list[MapEdge]:
    edges = []
    for floor in data["floors"]:
        for raw in floor.get("edges", []):
            source, target, length, oneway = file_edge_ends(raw)
            if length is None:
                length = straight_line(waypoints[source], waypoints[target])
            edges.append(
                MapEdge(
                    source=source,
                    target=target,
                    length=float(length),
                    oneway=oneway,
                    guarded_by=guard_of(guards, source, target, oneway),
                )
            )
    return edges


def guard_of(
    guards: Mapping[tuple[str, str], str], source: str, target: str, oneway: bool
) -> str | None:
    """The resource guarding an edge; a guard may name a two-way edge in either direction."""
    found = guards.get((source, target))
    if found is None and not oneway:
        found = guards.get((target, source))
    return found


def _file_resources(resources: list[dict]) -> list[MapResource]:
    return [
        MapResource(
            id=n,
            code=r["code"],
            name=r.get("name", ""),
            kind=r["kind"],
            capacity=r.get("capacity", 1),
            seconds_per_floor=float(r.get("seconds_per_floor", 0.0)),
            overhead_seconds=float(r.get("overhead_seconds", 0.0)),
            waypoints=tuple(r["stops"].values()) if r["kind"] == ELEVATOR else tuple(r["waiting"]),
            names=names_tuple(r.get("names")),
        )
        for n, r in enumerate(resources, start=1)
    ]


# --- Routing ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Leg:
    seconds: float
    path: list[str]  # waypoint codes, both ends included; empty when unreachable
    via: list[str]  # per elevator ride: boarding then alighting waiting waypoint
    resources: list[str]  # guarding doors/corridors crossed and elevators ridden, in order
    metres: float = 0.0  # driven (elevator rides excluded)
    rides: int = 0  # elevator rides


@dataclass(frozen=True)
class _Link:
    target: str
    seconds: float
    resource: str | None = None
    ride: bool = False


@dataclass(frozen=True)
class _Tree:
    """Shortest paths from one source: seconds to each reached waypoint, and how it was reached."""

    seconds: dict[str, float]
    came_by: dict[str, tuple[str, _Link]]


class Router:
    """Travel times and legs on one SiteMap.

    Each source is searched at most once per Router (the scheduler asks thousands of times per
    allocation); its map never changes, so share one Router per map version (router_for).

    Routes avoid resources out of service where another way exists; a waypoint reachable only
    through one is still routed through it (the robot is then held in its queue until it is
    back in service, rather than its delivery failing).
    """

    def __init__(self, site_map: SiteMap):
        self.site_map = site_map
        avoid = site_map.out_of_service
        self._links = _links(site_map, avoid=avoid)
        self._all_links = _links(site_map) if avoid else None
        self._trees: dict[str, _Tree] = {}

    def travel_time(self, a: str, b: str) -> float:
        """Seconds from waypoint `a` to waypoint `b`; math.inf if there is no route."""
        self._check(b)
        return self._tree(a).seconds.get(b, math.inf)

    def travel_times_from(self, a: str) -> Mapping[str, float]:
        """Seconds from `a` to every waypoint it can reach."""
        return MappingProxyType(self._tree(a).seconds)

    def leg(self, a: str, b: str) -> Leg:
        self._check(b)
        tree = self._tree(a)
        if b not in tree.seconds:
            return Leg(seconds=math.inf, path=[], via=[], resources=[])
        steps = _steps_back(tree, b)
        driven = sum(link.seconds for _, link in steps if not link.ride)
        return Leg(
            seconds=tree.seconds[b],
            path=[a] + [link.target for _, link in steps],
            via=[code for source, link in steps if link.ride for code in (source, link.target)],
            resources=_collapse([link.resource for _, link in steps if link.resource]),
            metres=driven * self.site_map.robot_speed,
            rides=sum(link.ride for _, link in steps),
        )

    def _tree(self, source: str) -> _Tree:
        tree = self._trees.get(source)
        if tree is None:
            self._check(source)
            tree = self._trees[source] = self._search(source)
        return tree

    def _search(self, source: str) -> _Tree:
        tree = shortest_paths(self._links, source)
        if self._all_links is None or len(tree.seconds) == len(self._links):
            return tree
        # Waypoints cut off by a resource out of service: reached through it, as a fallback,
        # while every waypoint reachable without it keeps its way round.
        return shortest_paths(self._all_links, source, keep=tree)

    def _check(self, code: str) -> None:
        if code not in self.site_map.waypoints:
            raise KeyError(f"unknown waypoint {code!r}")


def _links(site_map: SiteMap, avoid: frozenset[str] = frozenset()) -> dict[str, list[_Link]]:
    links: dict[str, list[_Link]] = {code: [] for code in site_map.waypoints}
    for edge in site_map.edges:
        if edge.guarded_by in avoid:
            continue
        seconds = edge.length / site_map.robot_speed
        links[edge.source].append(_Link(edge.target, seconds, edge.guarded_by))
        if not edge.oneway:
            links[edge.target].append(_Link(edge.source, seconds, edge.guarded_by))
    for resource in site_map.resources.values():
        if resource.is_elevator and resource.code not in avoid:
            _add_rides(links, resource, site_map.waypoints)
    return links


def _add_rides(
    links: dict[str, list[_Link]], elevator: MapResource, waypoints: Mapping[str, MapWaypoint]
) -> None:
    """An elevator links every pair of its stops, both ways."""
    stops = [waypoints[code] for code in elevator.waypoints if code in waypoints]
    for a in stops:
        for b in stops:
            if a.code != b.code:
                seconds = elevator.overhead_seconds + elevator.seconds_per_floor * abs(
                    a.level - b.level
                )
                links[a.code].append(_Link(b.code, seconds, elevator.code, ride=True))


def shortest_paths(
    links: Mapping[str, list[_Link]], source: str, keep: _Tree | None = None
) -> _Tree:
    """Dijkstra from `source` over `links` (all costs are >= 0). With `keep`, the waypoints it
    reached keep their seconds and paths, and the search only extends it to the others."""
    seconds = dict(keep.seconds) if keep else {source: 0.0}
    came_by: dict[str, tuple[str, _Link]] = dict(keep.came_by) if keep else {}
    fixed = keep.seconds.keys() if keep else frozenset()
    done: set[str] = set()
    queue = [(so_far, code) for code, so_far in seconds.items()]
    heapq.heapify(queue)
    while queue:
        so_far, code = heapq.heappop(queue)
        if code in done:
            continue
        done.add(code)
        for link in links[code]:
            candidate = so_far + link.seconds
            if link.target in fixed:
                continue
            if candidate < seconds.get(link.target, math.inf):
                seconds[link.target] = candidate
                came_by[link.target] = (code, link)
                heapq.heappush(queue, (candidate, link.target))
    return _Tree(seconds=seconds, came_by=came_by)


def _path_steps(tree: _Tree, target: str):
    """(waypoint, how it was reached) along the shortest path to `target`."""
    while target in tree.came_by:
        yield target, tree.came_by[target]
        target = tree.came_by[target][0]


def _steps_back(tree: _Tree, target: str) -> list[tuple[str, _Link]]:
    """The (from, link) steps of the shortest path to `target`, in travel order."""
    steps = []
    while target in tree.came_by:
        source, link = tree.came_by[target]
        steps.append((source, link))
        target = source
    steps.reverse()
    return steps


def _collapse(codes: list[str]) -> list[str]:
    """Drop immediate repeats: two guarded edges of one corridor in a row are one passage."""
    return [code for n, code in enumerate(codes) if n == 0 or codes[n - 1] != code]


def names_tuple(value: Mapping[str, str] | None) -> tuple[tuple[str, str], ...]:
    """A site file's `names` (per language) as sorted pairs: hashable, for the frozen parts."""
    return tuple(sorted((value or {}).items()))
