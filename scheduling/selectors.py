"""Reads: robots' remaining routes for the allocator, tasks for the API, and what the pages
show (the schedule table, robots' current tasks and plans)."""

import math
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import datetime, timedelta

from django.db import connection
from django.db.models import (
    Case,
    IntegerField,
    Prefetch,
    Q,
    QuerySet,
    Value,
    When,
    prefetch_related_objects,
)
from django.utils import timezone
from django.utils.translation import gettext

from boards.choices import EventType
from boards.models import BoardMessage, RobotEvent
from core.plainsql import column, columns, loaded, table
from robots.choices import Presence, WaypointKind
from robots.mapcache import site_map, waypoint_by_id
from robots.models import Robot, Site, Waypoint
from robots.names import place_label
from robots.selectors import robot_position, waypoint_code
from scheduling.allocator import RobotRoute, Stop, TaskStops
from scheduling.choices import (
    FINISHED_STATUSES,
    HELD_STATUSES,
    PRIORITY_WEIGHT,
    ROUTE_STATUSES,
    Cause,
    StopAction,
    TaskStatus,
)
from scheduling.deadlines import lateness_note
from scheduling.models import (
    CustodyEntry,
    RecurringRequest,
    RobotPlan,
    Task,
    TaskStop,
    TaskTransition,
)


@dataclass(frozen=True)
class HeldRoute:
    """A robot's remaining route as the server accounts for it, and the tasks on it."""

    robot: Robot
    route: RobotRoute
    tasks: dict[str, Task] = field(default_factory=dict)
    signature: tuple = ()

    @property
    def is_empty(self) -> bool:
        return not self.route.tasks


def robot_routes(
    *, robots: Iterable[Robot], now: datetime | None = None, excluding: Iterable[int] = ()
) -> dict[int, HeldRoute]:
    """Each robot's remaining route, in one query however many robots and tasks; without the
    tasks `excluding` names (by pk).

    Stops already done are left out; a task picked up has only its drop-offs left; the load
    is what the done pick-ups and drop-offs of the robot's tasks left on board. Each task's
    due time counts from `now`.
    """
    now = now or timezone.now()
    robots = {robot.pk: robot for robot in robots}
    excluding = set(excluding)
    stops = defaultdict(list)
    for stop in _route_stops(robots):
        if stop.task.robot_id in robots and stop.task_id not in excluding:
            stops[stop.task.robot_id].append(stop)
    return {pk: _held_route(robot, stops[pk], now) for pk, robot in robots.items()}


def _route_stops(robots: dict[int, Robot]) -> list[TaskStop]:
    """The stops of the robots' route tasks, by task and index, each with its task: of the
    robot alone, of its site's robots (every allocation and every heartbeat reporting progress
    reads them: plain SQL on PostgreSQL, _ROUTE_STOPS), or of any other set of robots."""
    sites = {robot.site_id for robot in robots.values()}
    if connection.vendor == "postgresql" and len(sites) == 1:
        if len(robots) == 1:
            return _route_stops_read(_ROUTE_STOPS_OF_ROBOT, next(iter(robots)))
        return _route_stops_read(_ROUTE_STOPS_OF_SITE, sites.pop())
    if len(robots) == 1:
        return list(_route_stops_of(task__robot_id=next(iter(robots))))
    if len(sites) == 1:
        return list(_route_stops_of(task__site_id=sites.pop(), task__robot__isnull=False))
    return list(_route_stops_of(task__robot__in=list(robots)))


def _route_stops_read(sql: str, robot_or_site_id: int) -> list[TaskStop]:
    """_route_stops_of's stops through one of its plain SQL twins, one Task per task."""
    width, tasks, stops = len(TaskStop._meta.concrete_fields), {}, []
    with connection.cursor() as cursor:
        cursor.execute(sql, [_ROUTE_STATUS_VALUES, robot_or_site_id])
        for row in cursor.fetchall():
            stop = loaded(TaskStop, row[:width])
            if stop.task_id not in tasks:
                tasks[stop.task_id] = loaded(Task, row[width:])
            stop.task = tasks[stop.task_id]
            stops.append(stop)
    return stops


def _route_stops_of(**where) -> QuerySet[TaskStop]:
    stops = TaskStop.objects.filter(task__status__in=ROUTE_STATUSES, **where)
    return stops.select_related("task").order_by("task_id", "index")


# _route_stops_of(task__robot_id=...) and (task__site_id=..., task__robot__isnull=False): the
# stops of the route tasks, built once from the models (core/plainsql.py): Django compiles
# these wide joined rows again on every call, a noticeable share of a nurse's request that is
# allocated in the request (bench/request_cpu.py --allocating).
_ROUTE_STATUS_VALUES = [str(status) for status in ROUTE_STATUSES]
_ROUTE_STOPS = (
    f"SELECT {columns(TaskStop, 's')}, {columns(Task, 't')} "
    f"FROM {table(TaskStop)} s "
    f"JOIN {table(Task)} t "
    f"ON {column(Task, 'id', 't')} = {column(TaskStop, 'task', 's')} "
    f"WHERE {column(Task, 'status', 't')} = ANY(%s) AND "
)
_ORDER = f" ORDER BY {column(TaskStop, 'task', 's')}, {column(TaskStop, 'index', 's')}"
_ROUTE_STOPS_OF_ROBOT = f"{_ROUTE_STOPS}{column(Task, 'robot', 't')} = %s{_ORDER}"
_ROUTE_STOPS_OF_SITE = (
    f"{_ROUTE_STOPS}{column(Task, 'site', 't')} = %s "
    f"AND {column(Task, 'robot', 't')} IS NOT NULL{_ORDER}"
)


def robot_plan_current(robot_id: int) -> RobotPlan | None:
    """The last plan posted for the robot, with its board message (None if none or gone): every
    plan posted reads it (plain SQL on PostgreSQL, _PLAN_CURRENT, as _route_stops)."""
    if connection.vendor != "postgresql":
        return RobotPlan.objects.filter(robot_id=robot_id).select_related("message").first()
    with connection.cursor() as cursor:
        cursor.execute(_PLAN_CURRENT, [robot_id])
        row = cursor.fetchone()
    if row is None:
        return None
    width = len(RobotPlan._meta.concrete_fields)
    plan = loaded(RobotPlan, row[:width])
    plan.message = None if plan.message_id is None else loaded(BoardMessage, row[width:])
    return plan


_PLAN_CURRENT = (
    f"SELECT {columns(RobotPlan, 'p')}, {columns(BoardMessage, 'm')} "
    f"FROM {table(RobotPlan)} p "
    f"LEFT JOIN {table(BoardMessage)} m "
    f"ON {column(BoardMessage, 'id', 'm')} = {column(RobotPlan, 'message', 'p')} "
    f"WHERE {column(RobotPlan, 'robot', 'p')} = %s"
)


def robot_route(
    *, robot: Robot, now: datetime | None = None, excluding: Iterable[int] = ()
) -> HeldRoute:
    return robot_routes(robots=[robot], now=now, excluding=excluding)[robot.pk]


def task_stops(
    task: Task, stops: Iterable[TaskStop], *, site: Site, now: datetime | None = None
) -> TaskStops:
    """The allocator's view of a task: its remaining stops, pick-ups then drop-offs, its due
    time in seconds from `now` and its priority's weight."""
    remaining = [_stop(site, task, stop) for stop in stops if stop.is_remaining]
    due = (task.due_at - (now or timezone.now())).total_seconds() if task.due_at else math.inf
    return TaskStops(
        code=task.code,
        pickups=tuple(stop for stop in remaining if stop.action == StopAction.PICKUP),
        dropoffs=tuple(stop for stop in remaining if stop.action == StopAction.DROPOFF),
        due=due,
        weight=PRIORITY_WEIGHT.get(task.priority, 1.0),
    )


def robot_pace(robot: Robot) -> tuple[float, float]:
    """(its travel over the map's estimate, seconds at a stop) for the robot's ETAs: learned
    from its events (scheduling.services.etas), else 1 and the site's stop_dwell_seconds."""
    pace = 1.0 if robot.pace_travel is None else robot.pace_travel
    dwell = robot.site.stop_dwell_seconds if robot.pace_dwell is None else robot.pace_dwell
    return pace, dwell


def _held_route(robot: Robot, stops: list[TaskStop], now: datetime) -> HeldRoute:
    by_task = defaultdict(list)
    for stop in stops:
        by_task[stop.task].append(stop)
    held = [task_stops(task, its, site=robot.site, now=now) for task, its in by_task.items()]
    pace, dwell = robot_pace(robot)
    route = RobotRoute(
        robot=robot.code,
        start=robot_position(robot),
        load=sum(stop.load_change for stop in stops if stop.done_at),
        capacity=robot.capacity,
        tasks=tuple(task for task in held if task.pickups or task.dropoffs),
        dwell=dwell,
        pace=pace,
        lockable=len(robot.lockable_compartments),
        secure_load=sum(stop.load_change for stop in stops if stop.done_at and stop.task.secure),
        wear=robot.tasks_given,
    )
    signature = tuple((s.pk, s.task.status, s.is_remaining) for s in stops)
    tasks = {task.code: task for task in by_task}
    return HeldRoute(robot=robot, route=route, tasks=tasks, signature=signature)


def _stop(site: Site, task: Task, stop: TaskStop) -> Stop:
    place = waypoint_code(site, stop.waypoint_id)
    return Stop(task.code, stop.index, place, stop.action, stop.load_change, task.secure)


def stations_by_code(*, site: Site, codes: Iterable[str]) -> dict[str, Waypoint]:
    """The stations among `codes`, from the site's map as cached for its current version
    (robots.mapcache): every delivery request names its stations, and the map a heartbeat is
    checked against is the one a request is (no query, bench/latency.py)."""
    current = site_map(site)
    found = {}
    for code in set(codes):
        waypoint = current.waypoints.get(code)
        if waypoint is not None and waypoint.kind == WaypointKind.STATION:
            found[code] = _waypoint_row(site, current.floor_ids[waypoint.floor], waypoint)
    return found


def _waypoint_row(site: Site, floor_id: int, waypoint) -> Waypoint:
    """The Waypoint row the cached map was read from, as the database would give it."""
    values = (waypoint.id, site.pk, floor_id, waypoint.code, waypoint.name, waypoint.kind)
    row = Waypoint.from_db(None, _WAYPOINT_FIELDS, (*values, waypoint.x, waypoint.y))
    row.site = site
    return row


_WAYPOINT_FIELDS = ["id", "site_id", "floor_id", "code", "name", "kind", "x", "y"]


def task_list(*, status: str | None = None) -> QuerySet[Task]:
    tasks = Task.objects.select_related("site", "robot", "requester", "recurring").prefetch_related(
        _STOPS
    )
    return tasks.filter(status=status) if status else tasks


def task_detail(*, code: str) -> Task | None:
    return task_list().prefetch_related(_HISTORY).with_code(code).first()


def task_detail_of(task: Task) -> Task:
    """task_detail of a task this request holds, having just created or changed it: its row,
    site, requester, robot and recurring request as the request has them (kept up to date by
    the services that changed them), its stops and history read by two queries (a prefetch,
    as task_detail's)."""
    prefetch_related_objects([task], _STOPS, _HISTORY)
    return task


_STOPS = Prefetch("stops", queryset=TaskStop.objects.select_related("waypoint"))
_HISTORY = Prefetch(
    "history", queryset=TaskTransition.objects.select_related("robot", "event", "user")
)


def given_back_entries(task: Task) -> list[TaskTransition]:
    """The give-backs in a task's prefetched history (task_detail), oldest first."""
    return [e for e in task.history.all() if _is_give_back(e)]


def _is_give_back(entry: TaskTransition) -> bool:
    held = (TaskStatus.ASSIGNED, TaskStatus.ACKNOWLEDGED)
    return entry.new == TaskStatus.DUE and entry.old in held and entry.cause in GIVE_BACK_CAUSES


def custody_between(*, site: Site, start: datetime, end: datetime) -> QuerySet[CustodyEntry]:
    """The site's hand-offs from start (included) to end (excluded), in order (one query)."""
    entries = CustodyEntry.objects.filter(task__site=site, at__gte=start, at__lt=end)
    return entries.select_related("task", "task__requester", "robot").order_by("at", "id")


def history_in_words(task: Task) -> list[tuple[TaskTransition, str]]:
    """Each entry of a task's history (prefetched, task_detail) with its note in plain words:
    an assignment after a give-back says why ("R1 went offline: reassigned to R3")."""
    lines, given_back = [], None
    for entry in task.history.all():
        note = entry.text
        if _is_give_back(entry):
            given_back = entry
        elif entry.cause == Cause.ALLOCATION and entry.robot is not None:
            if given_back is not None:
                why = given_back.text or gettext("Taken from its robot")
                said = gettext("%(why)s: reassigned to %(robot)s")
                note = said % {"why": why, "robot": entry.robot}
            else:
                note = note or gettext("Given to %(robot)s") % {"robot": entry.robot}
            given_back = None
        lines.append((entry, note))
    return lines


# --- Pages -------------------------------------------------------------------------------------

SCHEDULE_ROWS = 200  # the schedule table shows at most this many tasks
RECENTLY_FINISHED = timedelta(minutes=30)  # finished tasks stay in the table this long


# Causes that take a task from its robot before it was loaded: a give-back.
GIVE_BACK_CAUSES = [Cause.PRESENCE, Cause.USER, Cause.ROBOT_FAULT, Cause.ACK_TIMEOUT]


def _given_back():
    """The history entries where a task was taken from its robot (oldest first)."""
    held = [TaskStatus.ASSIGNED, TaskStatus.ACKNOWLEDGED]
    return TaskTransition.objects.filter(
        new=TaskStatus.DUE, old__in=held, cause__in=GIVE_BACK_CAUSES
    ).order_by("id")


@dataclass(frozen=True)
class ScheduleRow:
    task: Task
    pickups: list[str]  # station names
    dropoffs: list[str]
    notice: str = ""  # what disrupts it, in plain words ("Held by an operator")
    on_hold: bool = False  # its robot is stopped: the stored ETA does not hold

    @property
    def finished(self) -> bool:
        return self.task.status in FINISHED_STATUSES

    @property
    def lateness(self) -> str:
        """ "earliest drop-off 14:32, 7 min after it is due" while not delivered, else ""."""
        if self.task.delivered_at is not None or self.finished:
            return ""
        return lateness_note(eta=self.task.eta, due_at=self.task.due_at)


def task_disruption(task: Task, given_back: list[TaskTransition]) -> tuple[str, bool]:
    """What keeps the task from going as planned, for its requester, and whether its robot is
    stopped; ("", False) if nothing. `given_back`: its give-back entries (_given_back)."""
    if task.status in FINISHED_STATUSES or task.status == TaskStatus.DELIVERED:
        return "", False
    robot = task.robot if task.status in ROUTE_STATUSES else None
    if robot is not None and robot.fault_at is not None:
        return gettext("%(robot)s reported a fault: operators are alerted") % {
            "robot": robot.code
        }, True
    if robot is not None and robot.paused_by_operator:
        return gettext("Held by an operator"), True
    if robot is not None and robot.presence == Presence.OFFLINE:
        return gettext("%(robot)s is offline: operators are alerted") % {"robot": robot.code}, True
    if task.unattended_at is not None:
        return gettext("Nobody unloaded it at the drop-off: on its way back, not delivered"), False
    if not given_back:
        return "", False
    why = given_back[-1].text or gettext("Taken from its robot")
    if robot is not None:
        return gettext("%(why)s: reassigned to %(robot)s") % {
            "why": why,
            "robot": robot.code,
        }, False
    if task.status == TaskStatus.DUE:
        return gettext("%(why)s: waiting for another robot") % {"why": why}, False
    return "", False


def schedule_for_site(*, site: Site, now: datetime) -> list[ScheduleRow]:
    """The schedule table (the paper's Figure 4b): every task not finished, by requested time,
    then those finished within RECENTLY_FINISHED, newest first. Two queries, however many rows;
    station names come from the cached map."""
    since = now - RECENTLY_FINISHED
    recent = Q(completed_at__gte=since) | Q(cancelled_at__gte=since) | Q(failed_at__gte=since)
    finished = Case(
        When(status__in=FINISHED_STATUSES, then=Value(1)),
        default=Value(0),
        output_field=IntegerField(),
    )
    tasks = (
        Task.objects.filter(site=site)
        .filter(~Q(status__in=FINISHED_STATUSES) | recent)
        .annotate(finished=finished)
        .order_by("finished", "requested_time", "pk")
        .select_related("robot")
        .prefetch_related(
            Prefetch("stops", queryset=TaskStop.objects.order_by("index")),
            Prefetch("history", queryset=_given_back(), to_attr="given_back"),
        )
    )
    rows = [_schedule_row(site, task) for task in tasks[:SCHEDULE_ROWS]]
    done = [row for row in rows if row.finished]
    return [row for row in rows if not row.finished] + done[::-1]


def _schedule_row(site: Site, task: Task) -> ScheduleRow:
    stops = [stop for stop in task.stops.all() if stop.skipped_at is None]
    notice, on_hold = task_disruption(task, task.given_back)
    return ScheduleRow(
        task=task,
        pickups=[_label(site, s) for s in stops if s.action == StopAction.PICKUP],
        dropoffs=[_label(site, s) for s in stops if s.action == StopAction.DROPOFF],
        notice=notice,
        on_hold=on_hold,
    )


def _label(site: Site, stop: TaskStop) -> str:
    waypoint = waypoint_by_id(site, stop.waypoint_id)
    return place_label(waypoint) if waypoint else "?"


def stations_for_site(*, site: Site) -> list[tuple[str, str]]:
    """(code, name) of the stations nurses can pick, by name (from the cached map)."""
    stations = site_map(site).codes_of_kind(WaypointKind.STATION)
    waypoints = site_map(site).waypoints
    named = ((code, place_label(waypoints[code])) for code in stations)
    return sorted(named, key=lambda s: s[1])


def station_options(*, site: Site) -> list[dict[str, str]]:
    """The stations for the request form's search, by name: each one's code, name and ward
    (its floor's name, else the floor's code), from the cached map."""
    current = site_map(site)
    options = []
    for code, name in stations_for_site(site=site):
        floor = current.waypoints[code].floor
        ward = current.floor_names.get(floor) or floor
        options.append({"code": code, "name": name, "ward": ward})
    return options


def tasks_by_robot(*, robots: Iterable[Robot]) -> dict[int, list[Task]]:
    """The tasks each robot holds (assigned to delivered), oldest first; one query."""
    held: dict[int, list[Task]] = defaultdict(list)
    tasks = Task.objects.filter(robot__in=list(robots), status__in=HELD_STATUSES).order_by("pk")
    for task in tasks.only("pk", "robot_id", "status", "contents", "return_trip"):
        held[task.robot_id].append(task)
    return held


@dataclass(frozen=True)
class PlanStop:
    task: str | None
    stop: int | None
    action: str
    waypoint: str
    place: str
    via: list[str]


@dataclass(frozen=True)
class PlanView:
    version: int
    posted_at: datetime
    acked_at: datetime | None
    stops: list[PlanStop]


def robot_plan(*, robot: Robot) -> PlanView | None:
    """The last plan posted for the robot, its places named from the cached map; one query."""
    plan = RobotPlan.objects.filter(robot=robot).select_related("message").first()
    if plan is None:
        return None
    places = site_map(robot.site).waypoints

    def place(code: str) -> str:
        return place_label(places[code]) if code in places else code

    stops = [
        PlanStop(
            task=stop.get("task"),
            stop=stop.get("stop"),
            action=stop.get("action", ""),
            waypoint=stop.get("waypoint", ""),
            place=place(stop.get("waypoint", "")),
            via=[place(code) for code in stop.get("via", [])],
        )
        for stop in plan.body.get("stops", [])
    ]
    acked_at = plan.message.acked_at if plan.message else None
    return PlanView(version=plan.version, posted_at=plan.posted_at, acked_at=acked_at, stops=stops)


# --- The receiving station's view ----------------------------------------------------------------

APPROACHING = timedelta(minutes=2)  # a robot this close (by its ETA) is announced


@dataclass(frozen=True)
class Incoming:
    """A delivery on its way to a station: what the receiving unit sees of it."""

    task: Task
    stop: TaskStop
    robot: Robot | None
    arrived_at: datetime | None  # the robot is there, waiting to be unloaded, since
    approaching: bool  # due within APPROACHING
    pin: str | None = None  # a secure delivery's PIN, set by the page for those who may see it

    @property
    def is_here(self) -> bool:
        return self.arrived_at is not None


def station_incoming(*, site: Site, station: Waypoint, now: datetime) -> list[Incoming]:
    """The deliveries with a drop-off still to do at `station`, the robots there first, then
    by ETA. Three queries (the stops with their tasks and robots, the arrivals)."""
    stops = list(
        TaskStop.objects.remaining()
        .filter(waypoint=station, action=StopAction.DROPOFF, task__status__in=ROUTE_STATUSES)
        .select_related("task", "task__robot")
    )
    arrived = _arrivals(stops)
    rows = []
    for stop in stops:
        task, robot = stop.task, stop.task.robot
        on_board = task.status == TaskStatus.PICKED_UP
        here = on_board and robot is not None and robot.waypoint_id == station.pk
        arrived_at = arrived.get((task.code, stop.index), now) if here else None
        soon = task.eta is not None and task.eta - now <= APPROACHING
        rows.append(Incoming(task, stop, robot, arrived_at, approaching=soon and not here))
    far = now + timedelta(days=365)
    return sorted(rows, key=lambda r: (not r.is_here, r.task.eta or far, r.task.pk))


def _arrivals(stops: list[TaskStop]) -> dict[tuple[str, int], datetime]:
    """When each stop's robot reported `arrived` there (the newest report)."""
    codes = [stop.task.code for stop in stops if stop.task.robot_id]
    if not codes:
        return {}
    found = RobotEvent.objects.filter(type=EventType.ARRIVED, task__in=codes)
    found = found.order_by("received_at").only("task", "stop", "received_at")
    return {(e.task, e.stop): e.received_at for e in found}


def recurring_for(*, site: Site, user, everyone: bool) -> QuerySet[RecurringRequest]:
    """The site's running periodic requests: everyone's (operators) or the user's own."""
    series = RecurringRequest.objects.filter(site=site, active=True).select_related("requester")
    return (series if everyone else series.filter(requester=user)).order_by("id")


def repeat_in_words(repeat: dict) -> str:
    """{"times": ["08:00", "14:00"]} -> "every day at 08:00, 14:00"."""
    if repeat.get("times"):
        return f"every day at {', '.join(repeat['times'])}"
    window = f", {repeat['from']}–{repeat['until']}" if "from" in repeat else ""
    return f"every {repeat.get('every_minutes')} min{window}"
