"""A floor drawn from the site's cached map, for the fleet page's SVG
(templates/robots/_floor_map.html)."""

from dataclasses import dataclass, field, replace

from robots.choices import WaypointKind
from robots.mapcache import site_map
from robots.models import Site
from robots.names import floor_label, place_label

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
    label_y: float | None = None  # its name's baseline from the point; None: not written
    resources_y: float | None = None  # likewise for the resources it is a waiting area of
    resources_label: str = ""  # those of them not already written at another point of the floor

    @property
    def label_x(self) -> float:
        return {"start": -LABEL_INSET, "end": LABEL_INSET}.get(self.anchor, 0.0)


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
    return [(code, _floor_label(code, floor_label(current, code))) for code in ordered]


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
        name=_floor_label(floor, floor_label(current, floor)),
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
        label = place_label(wp)
        drawing.waypoints.append(DrawnWaypoint(code, label, wp.kind, x, y, resources, anchor))
    drawing.waypoints[:] = _labels_placed(drawing.waypoints)
    for edge in current.edges:
        if edge.source in points and edge.target in points:
            (x1, y1), (x2, y2) = (
                drawing.place(points[c].x, points[c].y) for c in (edge.source, edge.target)
            )
            drawing.edges.append(DrawnEdge(x1, y1, x2, y2, edge.guarded_by, edge.oneway))
    return drawing


# Plain waypoints first, so the symbols of stations, docks and waiting areas are drawn on top.
_KIND_ORDER = {WaypointKind.PLAIN: 0, WaypointKind.RESOURCE_WAIT: 1}


# Labels in drawing units (metres), as static/css/app.css draws them (.wp-label: 1.45px).
LABEL_SIZE = 1.45
LABEL_CHAR = 0.56 * LABEL_SIZE  # an average character's width in the system's sans-serif
LABEL_INSET = 1.3  # a label anchored at its start or end begins this far on the other side
LABEL_ABOVE, LABEL_BELOW = -2.1, 3.2  # baselines from the point
SYMBOL = 1.4  # half the size of a station's, dock's or waiting area's symbol


def _labels_placed(waypoints: list[DrawnWaypoint]) -> list[DrawnWaypoint]:
    """Each label above its point, else below, where it covers no other label or symbol;
    one that fits nowhere is left out (the point's tooltip still names it), so labels
    never run into each other ("RoboRoRobot base dock 4 3"). A resource is written once per
    floor, at the first of its waiting areas (a door has one on each side)."""
    taken = [_symbol_box(wp) for wp in waypoints if wp.kind != WaypointKind.PLAIN]
    written: set[str] = set()
    placed = []
    for wp in waypoints:
        label_y = resources_y = None
        if wp.kind in (WaypointKind.STATION, WaypointKind.DOCK):
            label_y = _free_line(wp, wp.label, taken, [LABEL_ABOVE, LABEL_BELOW])
        text = ", ".join(code for code in wp.resources if code not in written)
        if text:
            lines = [LABEL_BELOW, LABEL_ABOVE]
            resources_y = _free_line(wp, text, taken, [y for y in lines if y != label_y])
        if resources_y is not None:
            written.update(wp.resources)
        label = text if resources_y is not None else ""
        placed.append(replace(wp, label_y=label_y, resources_y=resources_y, resources_label=label))
    return placed


def _free_line(wp: DrawnWaypoint, text: str, taken: list, baselines: list[float]):
    for baseline in baselines:
        box = _text_box(wp, text, baseline)
        if not any(_overlap(box, other) for other in taken):
            taken.append(box)
            return baseline
    return None


def _text_box(wp: DrawnWaypoint, text: str, baseline: float) -> tuple:
    width = len(text) * LABEL_CHAR
    left = wp.x + wp.label_x - {"start": 0, "end": width}.get(wp.anchor, width / 2)
    top = wp.y + baseline - LABEL_SIZE
    return left, top, left + width, wp.y + baseline + 0.3 * LABEL_SIZE


def _symbol_box(wp: DrawnWaypoint) -> tuple:
    return wp.x - SYMBOL, wp.y - SYMBOL, wp.x + SYMBOL, wp.y + SYMBOL


def _overlap(a: tuple, b: tuple) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


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
