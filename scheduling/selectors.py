"""Reads: robots' remaining routes for the allocator, and tasks for the API."""

from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field

from django.db.models import Prefetch, QuerySet

from robots.choices import WaypointKind
from robots.models import Robot, Site, Waypoint
from robots.selectors import robot_position, waypoint_code
from scheduling.allocator import RobotRoute, Stop, TaskStops
from scheduling.choices import ROUTE_STATUSES, StopAction
from scheduling.models import Task, TaskStop, TaskTransition


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


def robot_routes(*, robots: Iterable[Robot]) -> dict[int, HeldRoute]:
    """Each robot's remaining route, in one query however many robots and tasks.

    Stops already done are left out; a task picked up has only its drop-offs left; the load
    is what the done pick-ups and drop-offs of the robot's tasks left on board.
    """
    robots = {robot.pk: robot for robot in robots}
    stops = defaultdict(list)
    for stop in (
        TaskStop.objects.filter(task__robot__in=list(robots), task__status__in=ROUTE_STATUSES)
        .select_related("task")
        .order_by("task_id", "index")
    ):
        stops[stop.task.robot_id].append(stop)
    return {pk: _held_route(robot, stops[pk]) for pk, robot in robots.items()}


def robot_route(*, robot: Robot) -> HeldRoute:
    return robot_routes(robots=[robot])[robot.pk]


def task_stops(task: Task, stops: Iterable[TaskStop], *, site: Site) -> TaskStops:
    """The allocator's view of a task: its remaining stops, pick-ups then drop-offs."""
    remaining = [_stop(site, task, stop) for stop in stops if stop.is_remaining]
    return TaskStops(
        code=task.code,
        pickups=tuple(stop for stop in remaining if stop.action == StopAction.PICKUP),
        dropoffs=tuple(stop for stop in remaining if stop.action == StopAction.DROPOFF),
    )


def _held_route(robot: Robot, stops: list[TaskStop]) -> HeldRoute:
    by_task = defaultdict(list)
    for stop in stops:
        by_task[stop.task].append(stop)
    held = [task_stops(task, its, site=robot.site) for task, its in by_task.items()]
    route = RobotRoute(
        robot=robot.code,
        start=robot_position(robot),
        load=sum(stop.load_change for stop in stops if stop.done_at),
        capacity=robot.capacity,
        tasks=tuple(task for task in held if task.pickups or task.dropoffs),
    )
    signature = tuple((s.pk, s.task.status, s.is_remaining) for s in stops)
    tasks = {task.code: task for task in by_task}
    return HeldRoute(robot=robot, route=route, tasks=tasks, signature=signature)


def _stop(site: Site, task: Task, stop: TaskStop) -> Stop:
    place = waypoint_code(site, stop.waypoint_id)
    return Stop(task.code, stop.index, place, stop.action, stop.load_change)


def stations_by_code(*, site: Site, codes: Iterable[str]) -> dict[str, Waypoint]:
    return {
        wp.code: wp
        for wp in Waypoint.objects.filter(site=site, code__in=set(codes), kind=WaypointKind.STATION)
    }


def task_list(*, status: str | None = None) -> QuerySet[Task]:
    tasks = Task.objects.select_related("site", "robot", "requester", "recurring").prefetch_related(
        Prefetch("stops", queryset=TaskStop.objects.select_related("waypoint"))
    )
    return tasks.filter(status=status) if status else tasks


def task_detail(*, code: str) -> Task | None:
    history = TaskTransition.objects.select_related("robot", "event", "user")
    return (
        task_list().prefetch_related(Prefetch("history", queryset=history)).with_code(code).first()
    )
