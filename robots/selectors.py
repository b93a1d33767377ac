"""Reads about robots: for other apps (the scheduler), which never reach further in, and for
the pages (fleet panel, floor map, robot page, alerts)."""

from dataclasses import dataclass, field

from django.db.models import QuerySet

from boards.models import RobotEvent
from robots.choices import Presence, RobotStatus, WaypointKind
from robots.models import Alert, Lease, OperatorAction, PresenceChange, Robot, Site
from robots.sitemap import site_map, waypoint_by_id

# Robots reporting these statuses are offered no new tasks.
UNAVAILABLE_STATUSES = [RobotStatus.ERROR, RobotStatus.PAUSED]
REACHABLE = [Presence.ONLINE, Presence.UNREACHABLE]


def robots_for_allocation(*, site: Site) -> list[Robot]:
    """Robots that may be offered a new task (protocol v1, "Presence"), by code.

    Online or unreachable, not reporting an error or a pause, not held by an operator (Pause
    or Return to dock, until Resume), and with a reported battery level at or above the
    site's threshold (a robot that never reported has none).
    """
    robots = list(available_robots(site).order_by("code"))
    for robot in robots:
        robot.site = site
    return robots


def available_robots(site: Site) -> QuerySet[Robot]:
    """The site's robots that may be offered a new task (see robots_for_allocation)."""
    return Robot.objects.filter(
        site=site,
        presence__in=REACHABLE,
        paused_by_operator=False,
        battery__isnull=False,
        battery__gte=site.battery_threshold,
    ).exclude(status__in=UNAVAILABLE_STATUSES)


def robot_position(robot: Robot) -> str:
    """The waypoint code a robot's route starts from: where it reported, else its dock.

    Reads the site's cached map, not the database (robot.site must be loaded).
    """
    return waypoint_code(robot.site, robot.waypoint_id or robot.dock_id)


def robot_dock(robot: Robot) -> str:
    return waypoint_code(robot.site, robot.dock_id)


def waypoint_code(site: Site, waypoint_id: int) -> str:
    waypoint = waypoint_by_id(site, waypoint_id)
    if waypoint is None:
        raise KeyError(waypoint_id)
    return waypoint.code


# --- Pages -------------------------------------------------------------------------------------

RECENT_EVENTS = 20
RECENT_PRESENCE = 10
RECENT_ACTIONS = 10
MAP_MARGIN = 6.0  # metres around a floor's drawing
MAP_MIN_SIZE = 20.0  # metres: a floor of one or two waypoints still gets a sensible drawing


def sites_all() -> list[Site]:
    return list(Site.objects.order_by("code"))


def alerts_open() -> QuerySet[Alert]:
    """Open alerts, newest first (lazy: one query when listed)."""
    return Alert.objects.open().select_related("site", "robot")


def fleet_snapshot(*, site: Site) -> list[Robot]:
    """The site's robots by code, in one query (their site set, so the map lookups need none)."""
    robots = list(Robot.objects.filter(site=site).order_by("code"))
    for robot in robots:
        robot.site = site
    return robots


@dataclass(frozen=True)
class QueuedLease:
    robot: str
    state: str
    state_label: str
    position: int | None  # 1 = next in line; None for holders


def resource_queues(*, site: Site) -> dict[str, list[QueuedLease]]:
    """Every resource's holders, then its queue in order, by resource code (one query)."""
    queues: dict[str, list[QueuedLease]] = {code: [] for code in site_map(site).resources}
    leases = (
        Lease.objects.live()
        .filter(resource__site=site)
        .with_queue_position()
        .in_queue_order()
        .select_related("robot", "resource")
    )
    for lease in leases:
        queues.setdefault(lease.resource.code, []).append(
            QueuedLease(
                robot=lease.robot.code,
                state=lease.state,
                state_label=lease.get_state_display(),
                position=lease.queue_position,
            )
        )
    return queues


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


@dataclass(frozen=True)
class RobotDetail:
    robot: Robot
    events: list[RobotEvent]
    presence_changes: list[PresenceChange]
    actions: list[OperatorAction]


def robot_detail(*, code: str) -> RobotDetail | None:
    """A robot with its recent events, presence changes and operator actions (four queries)."""
    robot = Robot.objects.filter(code=code).select_related("site", "dock").first()
    if robot is None:
        return None
    return RobotDetail(
        robot=robot,
        events=list(RobotEvent.objects.filter(robot=robot).order_by("-id")[:RECENT_EVENTS]),
        presence_changes=list(robot.presence_changes.all()[:RECENT_PRESENCE]),
        actions=list(robot.operator_actions.select_related("by", "message")[:RECENT_ACTIONS]),
    )
