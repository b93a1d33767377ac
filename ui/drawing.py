"""A floor drawn from the site's cached map, for the fleet page's SVG
(templates/robots/_floor_map.html)."""

from dataclasses import dataclass, field

from robots.choices import WaypointKind
from robots.mapcache import site_map
from robots.models import Site

MAP_MARGIN = 6.0  # metres around a floor's drawing
MAP_MIN_SIZE = 20.0  # metres: a floor of one or two waypoints still gets a sensible drawing


@dataclass(frozen=True)
class DrawnWaypoint:
    code: str
    label: str
    kind: str
    x: float
    y: float
    resources: tuple[str, ...] = ()
    anchor: str = "middle"  # of its label: "start" near the left edge, "end" near the right


@dataclass(frozen=True)
class DrawnEdge:
    x1: float
    y1: float
    x2: float
    y2: float
    guarded_by: str | None
    oneway: bool


@dataclass(frozen=True)
class FloorDrawing:
    """A floor in drawing coordinates (metres, y downwards, the floor's frame shifted)."""

    floor: str
    name: str
    width: float
    height: float
    min_x: float
    max_y: float
    waypoints: list[DrawnWaypoint] = field(default_factory=list)
    edges: list[DrawnEdge] = field(default_factory=list)

    @property
    def margin(self) -> float:
        return MAP_MARGIN

    @property
    def view_box(self) -> str:
        return f"0 0 {self.width:g} {self.height:g}"

    def place(self, x: float, y: float) -> tuple[float, float]:
        """Drawing coordinates of a point of the floor (y grows north on the floor)."""
        return round(x - self.min_x + MAP_MARGIN, 2), round(self.max_y - y + MAP_MARGIN, 2)


def floors_of(*, site: Site) -> list[tuple[str, str]]:
    """(code, label) of the site's floors, top floor first (from the cached map)."""
    current = site_map(site)
    ordered = sorted(current.floors, key=current.floors.get, reverse=True)
    return [(code, _floor_label(code, current.floor_names.get(code, ""))) for code in ordered]


def floor_drawing(*, site: Site, floor: str) -> FloorDrawing | None:
    """The drawing of one floor from the cached map (no query); None for an unknown floor."""
    current = site_map(site)
    if floor not in current.floors:
        return None
    points = {code: wp for code, wp in current.waypoints.items() if wp.floor == floor}
    xs, ys = [wp.x for wp in points.values()], [wp.y for wp in points.values()]
    min_x, max_y = min(xs), max(ys)
    width = max(max(xs) - min_x, MAP_MIN_SIZE) + 2 * MAP_MARGIN
    height = max(max_y - min(ys), MAP_MIN_SIZE / 2) + 2 * MAP_MARGIN
    drawing = FloorDrawing(
        floor=floor,
        name=_floor_label(floor, current.floor_names.get(floor, "")),
        width=round(width, 2),
        height=round(height, 2),
        min_x=min_x,
        max_y=max_y,
    )
    waiting = _waiting_for(current.resources.values())
    for code, wp in sorted(points.items(), key=lambda item: _KIND_ORDER.get(item[1].kind, 0)):
        x, y = drawing.place(wp.x, wp.y)
        resources = tuple(waiting.get(code, ()))
        anchor = _anchor(x / drawing.width)
        drawing.waypoints.append(DrawnWaypoint(code, wp.label, wp.kind, x, y, resources, anchor))
    for edge in current.edges:
        if edge.source in points and edge.target in points:
            (x1, y1), (x2, y2) = (
                drawing.place(points[c].x, points[c].y) for c in (edge.source, edge.target)
            )
            drawing.edges.append(DrawnEdge(x1, y1, x2, y2, edge.guarded_by, edge.oneway))
    return drawing


# Plain waypoints first, so the symbols of stations, docks and waiting areas are drawn on top.
_KIND_ORDER = {WaypointKind.PLAIN: 0, WaypointKind.RESOURCE_WAIT: 1}


def _anchor(across: float) -> str:
    """Where a label sits on its point, so labels near an edge stay inside the drawing."""
    if across < 0.2:
        return "start"
    return "end" if across > 0.8 else "middle"


def _waiting_for(resources) -> dict[str, list[str]]:
    waiting: dict[str, list[str]] = {}
    for resource in resources:
        for code in resource.waypoints:
            waiting.setdefault(code, []).append(resource.code)
    return waiting


def _floor_label(code: str, name: str) -> str:
    return f"{code} – {name}" if name else code
