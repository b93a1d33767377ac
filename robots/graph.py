"""The site graph and travel times, as pure Python (no Django), so the scheduler's allocator,
the robot-side simulator and tests can all use it.

A SiteMap is built either from the database (robots/sitemap.py) or from a parsed site file.
"""

from dataclasses import dataclass, field

ELEVATOR = "elevator"


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
    elevator_stops: dict[str, dict[str, str]] = field(
        default_factory=dict
    )  # elevator -> floor -> wp

    def serves_floor(self, resource_code: str, floor_code: str) -> bool:
        return floor_code in self.elevator_stops.get(resource_code, {})
