"""Plans on a robot's message board (protocol v1 `plan`): the whole remaining route.

Every function here is called with the robot's row locked (robots.services.robot_lock, or a
heartbeat or presence transaction), so plan versions and RobotPlan rows never race.
"""

import logging
from collections.abc import Sequence
from datetime import datetime

from boards import protocol
from boards.choices import MessageType
from boards.models import BoardMessage
from boards.services import board_post, board_withdraw
from robots.mapcache import router_for
from robots.models import Emergency, Robot
from robots.router import Router
from robots.selectors import robot_dock, robot_position, unit_badges
from scheduling.allocator import Stop, best_plan
from scheduling.choices import PRIORITY_ON_THE_WIRE, StopAction
from scheduling.models import RobotPlan, Task
from scheduling.selectors import HeldRoute, robot_pace, robot_plan_current, robot_route
from scheduling.services.etas import etas_set, etas_store, stop_times

logger = logging.getLogger(__name__)

PLAN_KEY = "plan"


def plan_post(
    *,
    robot: Robot,
    start: str,
    stops: Sequence[Stop],
    tasks: dict[str, Task],
    now: datetime,
    wake_at_once: bool = True,
    etas_changed: list[Task] | None = None,
) -> RobotPlan:
    """Post `stops` as the robot's plan, superseding any unacked plan; store the tasks' ETAs
    (by the robot's learned pace and dwell; the lease queues join them as it makes progress,
    scheduling.services.etas), or only set them and add the tasks whose ETAs changed to
    `etas_changed`, for a batch to write them all at once (etas_write).

    The robot is woken at once (its heartbeat waits for the commit), or with `wake_at_once`
    false once the transaction commits: for a batch that posts many plans, whose woken
    heartbeats would each hold a web worker while they wait for the rest of the batch."""
    router = router_for(robot.site)
    wire = _wire_stops(router, start, stops)
    on_route = {code: _task_wire(tasks[code]) for code in dict.fromkeys(s.task for s in stops)}
    # The plan first (the robot travels meanwhile), then its tasks' ETAs.
    current = robot_plan_current(robot.pk)
    plan = _post(robot, wire, on_route, now, current=current, wake_at_once=wake_at_once)
    pace, dwell = robot_pace(robot)
    times = stop_times(router, start, stops, pace=pace, dwell=dwell)
    if etas_changed is None:
        etas_store(tasks, times, now)
    else:
        etas_changed += etas_set(tasks, times, now)
    return plan


def plan_dock_post(*, robot: Robot, now: datetime) -> RobotPlan:
    """The plan of a robot with nothing left to do: back to its dock (to charge, if it was sent
    to charge: scheduling.services.charging)."""
    return _dock_post(robot, now, robot_plan_current(robot.pk))


def _dock_post(robot: Robot, now: datetime, current: RobotPlan | None) -> RobotPlan:
    dock = robot_dock(robot)
    via = router_for(robot.site).leg(robot_position(robot), dock).via
    stop = protocol.plan_dock_stop(waypoint=dock, via=via, charge=robot.sent_to_charge)
    return _post(robot, [stop], {}, now, current=current)


def robot_replan(*, robot: Robot, now: datetime, held: HeldRoute | None = None) -> RobotPlan:
    """Post the robot the best plan of what it holds now, or the dock plan if nothing."""
    held = held or robot_route(robot=robot, now=now)
    if held.is_empty:
        return plan_dock_post(robot=robot, now=now)
    plan = best_plan(held.route, router_for(robot.site).travel_time)
    if plan is None:  # the server's account overloads the robot: keep its tasks' own order
        logger.error("no feasible route for %s's tasks %s", robot.code, list(held.tasks))
        stops = [stop for task in held.route.tasks for stop in (*task.pickups, *task.dropoffs)]
    else:
        stops = list(plan.stops)
    return plan_post(robot=robot, start=held.route.start, stops=stops, tasks=held.tasks, now=now)


def robot_replan_if_changed(*, robot: Robot, now: datetime) -> RobotPlan | None:
    """Post a new plan if the best one on the map as it stands now (a resource out of or back
    in service) differs from the robot's current plan; None if it does not."""
    current = RobotPlan.objects.filter(robot=robot).first()
    if current is None:
        return None
    held = robot_route(robot=robot, now=now)
    router = router_for(robot.site)
    if held.is_empty:
        via = router.leg(robot_position(robot), robot_dock(robot)).via
        wire = [protocol.plan_dock_stop(waypoint=robot_dock(robot), via=via)]
    else:
        plan = best_plan(held.route, router.travel_time)
        if plan is None:
            return None
        wire = _wire_stops(router, held.route.start, list(plan.stops))
    if _same_route(wire, current.body.get("stops", [])):
        return None
    return robot_replan(robot=robot, now=now, held=held)


def _same_route(new: list[dict], old: list[dict]) -> bool:
    def route(stops):
        return [(s.get("task"), s.get("stop"), s["waypoint"], s.get("via", [])) for s in stops]

    return route(new) == route(old)


def robot_dock_if_idle(*, robot: Robot, now: datetime) -> RobotPlan | None:
    """Send a robot that has nothing left to do to its dock, unless that is its plan already."""
    if not robot_route(robot=robot, now=now).is_empty:
        return None
    current = robot_plan_current(robot.pk)
    if current is not None and current.is_dock:
        return None
    return _dock_post(robot, now, current)  # the plan read once (every delivery ends here)


def plan_restore(*, robot: Robot, now: datetime) -> RobotPlan | None:
    """After a restart (a new boot_id), post the robot a plan again if it lost the one it had
    acked: the version it reports is older than the last posted, and none is on its board.

    The plan is made afresh from where the robot is now, with a newer version, so a robot that
    applies only newer plans takes it. Called with the robot's row locked, from its first
    heartbeat after the restart."""
    current = robot_plan_current(robot.pk)
    if current is None or robot.plan_version >= current.version or _may_be_pending(current):
        return None
    logger.info("%s restarted without plan %d: posting it again", robot.code, current.version)
    return robot_replan(robot=robot, now=now)


def plan_refuge_post(*, robot: Robot, refuge: str, now: datetime) -> RobotPlan:
    """Send the robot to a refuge point for a fire alarm (scheduling.services.emergency): a
    `dock` stop there first, then the task stops of its current plan, so the tasks it holds
    stay its own while it waits. The refuge is recorded on the alarm first: every plan posted
    for the robot until the all-clear starts with it (_post)."""
    current = robot_plan_current(robot.pk)
    stops = current.body.get("stops", []) if current else []
    tasks = current.body.get("tasks", {}) if current else {}
    return _post(
        robot, [s for s in stops if s.get("action") != "dock"], tasks, now, current=current
    )


def plan_withdraw_pending(*, robot: Robot, reason: str, now: datetime) -> int:
    """Take the robot's unacked plan off its board (protocol v1, withdrawing an assignment)."""
    pending = BoardMessage.objects.pending().filter(robot=robot, key=PLAN_KEY)
    return board_withdraw(messages=pending, reason=reason, now=now)


def _post(
    robot: Robot,
    stops: list[dict],
    tasks: dict[str, dict],
    now: datetime,
    *,
    current: RobotPlan | None,
    wake_at_once=True,
) -> RobotPlan:
    """Post the plan after `current`, the robot's last plan as robot_plan_current read it."""
    refuge = _refuge_of(robot)
    if refuge is not None:  # the robot waits out a fire alarm there (plan_refuge_post)
        stops = _after_refuge(robot, refuge, stops)
    version = max(current.version if current else 0, robot.plan_version) + 1
    body = protocol.plan_body(version=version, stops=stops, tasks=tasks)
    message = board_post(
        robot=robot,
        type=MessageType.PLAN,
        key=PLAN_KEY,
        body=body,
        supersede=_may_be_pending(current),
        robot_locked=wake_at_once,  # its row is locked: woken at once, or else on commit
    )
    if current is None:
        return RobotPlan.objects.create(
            robot=robot, version=version, body=body, message=message, posted_at=now
        )
    current.version, current.body, current.message, current.posted_at = version, body, message, now
    current.save(update_fields=["version", "body", "message", "posted_at"])
    return current


def _after_refuge(robot: Robot, refuge: str, stops: list[dict]) -> list[dict]:
    """A dock stop at the refuge (on the robot's floor: no `via`), then the task stops, the
    first one's `via` from the refuge."""
    rest = [dict(stop) for stop in stops if stop.get("action") != "dock"]
    if rest:
        rest[0].pop("via", None)
        via = router_for(robot.site).leg(refuge, rest[0]["waypoint"]).via
        if via:
            rest[0]["via"] = via
    return [protocol.plan_dock_stop(waypoint=refuge, via=[]), *rest]


def _refuge_of(robot: Robot) -> str | None:
    """The refuge point the fire alarm in force sent the robot to; no query without one."""
    if robot.site.fire_alarm_since is None:
        return None
    active = Emergency.objects.active().filter(site_id=robot.site_id)
    refuges = active.values_list("refuges", flat=True).first() or {}
    return refuges.get(robot.code)


def _may_be_pending(current: RobotPlan | None) -> bool:
    """Whether the robot may have a plan on its board still. Only this module posts plans and
    each is recorded here, so once the last one is acked or withdrawn none is pending."""
    return current is None or current.message is None or current.message.is_pending


def _wire_stops(router: Router, start: str, stops: Sequence[Stop]) -> list[dict]:
    """The stops as the protocol sends them."""
    wire, previous = [], start
    for stop in stops:
        leg = router.leg(previous, stop.place)
        wire.append(
            protocol.plan_stop(
                task=stop.task,
                stop=stop.index,
                action=stop.action,
                waypoint=stop.place,
                via=leg.via,
            )
        )
        previous = stop.place
    return wire


def _task_wire(task: Task) -> dict:
    return protocol.plan_task(
        contents=task.contents,
        sender=task.sender,
        receiver=task.receiver,
        priority=PRIORITY_ON_THE_WIRE.get(task.priority, "normal"),
        pin=task.pin.wire() if task.pin else None,
        badges=_receivers_badges(task) if task.pin else (),
    )


def _receivers_badges(task: Task) -> list[dict]:
    """The badges that open a secure delivery: those of the users of the units it is still to
    be dropped off at (a return trip's: the unit it goes back to)."""
    dropoffs = task.stops.remaining().filter(action=StopAction.DROPOFF)
    return unit_badges(station_ids=dropoffs.values_list("waypoint_id", flat=True))
