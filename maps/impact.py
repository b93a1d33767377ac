"""What a new map would do to the running fleet: which robots' current routes cross something
it removes, and what forbids publishing it whatever the site chose (read-only)."""

from dataclasses import dataclass, field
from datetime import datetime

from django.db.models import Count

from maps.diff import MapDiff
from resources.models import Lease
from robots.choices import RobotStatus
from robots.mapcache import router_for
from robots.models import Robot, Site
from robots.selectors import robot_position
from scheduling.choices import FINISHED_STATUSES
from scheduling.models import RecurringRequest, RobotPlan, TaskStop
from scheduling.selectors import robot_routes


@dataclass(frozen=True)
class RouteCut:
    """A robot whose current route crosses what the new map removes."""

    robot: str
    crosses: tuple[str, ...]

    def wire(self) -> dict:
        return {"robot": self.robot, "crosses": list(self.crosses)}


@dataclass
class Impact:
    cut: list[RouteCut] = field(default_factory=list)  # re-planned, or refused, as the site chose
    blockers: list[str] = field(default_factory=list)  # refused whatever the site chose

    def wire(self) -> dict:
        return {"routes": [cut.wire() for cut in self.cut], "blockers": list(self.blockers)}


def rollout_impact(*, site: Site, diff: MapDiff, now: datetime) -> Impact:
    """Read on the live map (the site's cached router), before anything is written."""
    impact = Impact()
    robots = list(Robot.objects.filter(site=site).select_related("site").order_by("code"))
    impact.cut, heading = _routes_cut(site, robots, diff, now)
    impact.blockers = [
        *_robots_standing_on(robots, diff),
        *heading,
        *_leases_held(site, diff),
        *_deliveries_pending(site, diff),
        *_stations_with_history(site, diff),
        *_recurring_requests(site, diff),
    ]
    return impact


def _routes_cut(
    site: Site, robots: list[Robot], diff: MapDiff, now: datetime
) -> tuple[list[RouteCut], list[str]]:
    """Robots whose remaining route crosses what the map removes; and, as blockers, those
    driving to a removed waypoint right now: a robot takes a new plan from its next waypoint on
    (never in the middle of a hop), so that waypoint must stay even if it is re-planned."""
    plans = {plan.robot_id: plan for plan in RobotPlan.objects.filter(robot__in=robots)}
    held = robot_routes(robots=robots, now=now)
    router = router_for(site)
    cut, heading = [], []
    for robot in robots:
        plan = plans.get(robot.pk)
        if plan is None:
            continue
        start, places = robot_position(robot), _remaining(plan, held[robot.pk])
        crosses = _crossed(router, start, places, diff)
        if crosses:
            cut.append(RouteCut(robot.code, tuple(crosses)))
        moving = robot.status in (RobotStatus.MOVING, RobotStatus.IN_RESOURCE)
        ahead = router.leg(start, places[0]).path[1:2] if places and moving else []
        if ahead and ahead[0] in diff.removed_waypoints:
            heading.append(
                f"robot {robot.code} is on its way to waypoint {ahead[0]}, which the new map "
                "removes: publish once it has passed"
            )
    return cut, heading


def _remaining(plan: RobotPlan, held) -> list[str]:
    """The waypoints of the plan's stops the robot has still to visit, in the plan's order."""
    left = {(t.code, s.index) for t in held.route.tasks for s in (*t.pickups, *t.dropoffs)}
    return [
        stop["waypoint"]
        for stop in plan.body.get("stops", [])
        if stop.get("action") == "dock" or (stop.get("task"), stop.get("stop")) in left
    ]


def _crossed(router, start: str, places: list[str], diff: MapDiff) -> list[str]:
    crosses: dict[str, None] = {}
    previous = start
    for place in places:
        leg = router.leg(previous, place)
        for code in leg.path:
            if code in diff.removed_waypoints:
                crosses[f"waypoint {code}"] = None
        for a, b in zip(leg.path, leg.path[1:], strict=False):
            gone = diff.removed_waypoints
            if (a, b) in diff.removed_edges and a not in gone and b not in gone:
                crosses[f"edge {a} – {b}"] = None
        for code in leg.resources:
            if code in diff.removed_resources:
                crosses[f"resource {code}"] = None
        previous = place
    return list(crosses)


def _robots_standing_on(robots: list[Robot], diff: MapDiff) -> list[str]:
    return [
        f"robot {robot.code} is at waypoint {robot_position(robot)}, which the new map removes"
        for robot in robots
        if robot.waypoint_id and robot_position(robot) in diff.removed_waypoints
    ]


def _leases_held(site: Site, diff: MapDiff) -> list[str]:
    leases = (
        Lease.objects.live()
        .filter(resource__site=site, resource__code__in=diff.removed_resources)
        .select_related("robot", "resource")
        .order_by("resource__code", "robot__code")
    )
    return [
        f"robot {lease.robot.code} holds or waits for {lease.resource.code} "
        f"({lease.get_state_display().lower()}), which the new map removes"
        for lease in leases
    ]


def _deliveries_pending(site: Site, diff: MapDiff) -> list[str]:
    stops = (
        TaskStop.objects.filter(task__site=site, waypoint__code__in=diff.removed_waypoints)
        .exclude(task__status__in=FINISHED_STATUSES)
        .select_related("task", "waypoint")
        .order_by("task_id", "index")
    )
    return [
        f"delivery {stop.task.code} ({stop.task.get_status_display().lower()}) has its "
        f"{stop.get_action_display().lower()} at {stop.waypoint.code}, which the new map removes"
        for stop in stops
    ]


def _stations_with_history(site: Site, diff: MapDiff) -> list[str]:
    """A finished delivery's stops keep their waypoint for its history: such a station stays
    (keep it, or make it a plain waypoint so nobody can order deliveries to it)."""
    used = (
        TaskStop.objects.filter(task__site=site, waypoint__code__in=diff.removed_waypoints)
        .filter(task__status__in=FINISHED_STATUSES)
        .values("waypoint__code")
        .annotate(count=Count("task", distinct=True))
        .order_by("waypoint__code")
    )
    return [
        f"{row['waypoint__code']} is in the history of {row['count']} finished "
        "deliveries and cannot be removed: keep it, or make it a plain waypoint"
        for row in used
    ]


def _recurring_requests(site: Site, diff: MapDiff) -> list[str]:
    problems = []
    for recurring in RecurringRequest.objects.filter(site=site, active=True).order_by("pk"):
        gone = sorted(set(recurring.pickups + recurring.dropoffs) & diff.removed_stations)
        if gone:
            problems.append(
                f"periodic request {recurring.pk} goes to {', '.join(gone)}, which the new map "
                "removes: stop it first"
            )
    return problems
