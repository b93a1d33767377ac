"""Robot events and plan acknowledgements drive the task lifecycle (heartbeat_applied).

Runs inside the heartbeat's transaction with the robot row locked; plans posted here go out
in the same response. Unknown task codes and stops refuse the whole heartbeat (400).
"""

from dataclasses import dataclass
from datetime import datetime

from boards.choices import EventType, MessageType
from boards.models import BoardMessage, RobotEvent
from boards.services import AppliedHeartbeat, HeartbeatRejected
from robots.alerts import alert_raise
from robots.models import AlertKind, Robot
from scheduling.choices import HELD_STATUSES, Cause, StopAction, TaskStatus
from scheduling.models import Task, TaskStop
from scheduling.services.history import task_move, task_record
from scheduling.services.plans import robot_dock_if_idle, robot_replan

TASK_EVENTS = {
    EventType.TASK_RECEIVED,
    EventType.ARRIVED,
    EventType.LOADED,
    EventType.UNLOADED,
    EventType.TASK_COMPLETED,
    EventType.TASK_FAILED,
}
STOP_ACTIONS = {EventType.LOADED: StopAction.PICKUP, EventType.UNLOADED: StopAction.DROPOFF}


@dataclass
class _Heartbeat:
    robot: Robot
    now: datetime
    tasks: dict[str, Task]
    failed: bool = False
    finished: bool = False


def heartbeat_tasks_apply(*, applied: AppliedHeartbeat) -> None:
    """Apply the heartbeat's plan acks, then its new task events, in order."""
    plans = [message for message in applied.acked if message.type == MessageType.PLAN]
    events = [
        (applied.event_index.get(event.event_id, n), event)
        for n, event in enumerate(applied.events)
        if event.type in TASK_EVENTS and (event.task or event.type != EventType.ARRIVED)
    ]
    if not plans and not events:
        return  # the common heartbeat: no queries
    codes = {event.task for _, event in events} | {c for m in plans for c in _plan_tasks(m)}
    beat = _Heartbeat(applied.robot, applied.now, _tasks(applied.robot, codes))
    _check(events, beat.tasks)
    for message in plans:
        _plan_acked(beat, message)
    for _, event in events:
        _event_apply(beat, event)
    _replan_if_needed(beat)


def _plan_tasks(message: BoardMessage) -> list[str]:
    tasks = message.body.get("tasks")
    return list(tasks) if isinstance(tasks, dict) else []


def _tasks(robot: Robot, codes) -> dict[str, Task]:
    found = Task.objects.with_codes(codes).filter(site_id=robot.site_id)
    return {task.code: task for task in found.prefetch_related("stops")}


def _check(events: list[tuple[int, RobotEvent]], tasks: dict[str, Task]) -> None:
    errors: dict[str, list[str]] = {}
    for index, event in events:
        for name, problem in _problems(event, tasks):
            errors.setdefault(f"events[{index}].{name}", []).append(problem)
    if errors:
        raise HeartbeatRejected(errors)


def _problems(event: RobotEvent, tasks: dict[str, Task]):
    if not event.task:
        yield "task", f"required for {event.type}"
        return
    task = tasks.get(event.task)
    if task is None:
        yield "task", f"unknown task {event.task!r}"
        return
    action = STOP_ACTIONS.get(event.type)
    if action is None:
        return
    stop = _stop(task, event.stop)
    if event.stop is None:
        yield "stop", f"required for {event.type}"
    elif stop is None:
        yield "stop", f"{task.code} has no stop {event.stop}"
    elif stop.action != action:
        yield "stop", f"stop {event.stop} of {task.code} is a {stop.get_action_display().lower()}"


def _stop(task: Task, index: int | None) -> TaskStop | None:
    return next((stop for stop in task.stops.all() if stop.index == index), None)


def _holds(beat: _Heartbeat, task: Task) -> bool:
    return task.robot_id == beat.robot.pk and task.status in HELD_STATUSES


def _plan_acked(beat: _Heartbeat, message: BoardMessage) -> None:
    for code in _plan_tasks(message):
        task = beat.tasks.get(code)
        if task and _holds(beat, task) and task.status == TaskStatus.ASSIGNED:
            note = f"plan {message.public_id} acked"
            _acknowledge(beat, task, cause=Cause.ROBOT_ACK, robot=beat.robot, note=note)


def _acknowledge(beat: _Heartbeat, task: Task, **why) -> None:
    task.acknowledged_at, task.ack_due_at = beat.now, None
    fields = ["acknowledged_at", "ack_due_at"]
    task_move(task, TaskStatus.ACKNOWLEDGED, at=beat.now, fields=fields, **why)


def _event_apply(beat: _Heartbeat, event: RobotEvent) -> None:
    task = beat.tasks[event.task]
    why = {"cause": Cause.ROBOT_EVENT, "robot": beat.robot, "event": event}
    if not _holds(beat, task):
        held = "not its task" if task.robot_id != beat.robot.pk else f"the task is {task.status}"
        note = f"{event.type} from {beat.robot.code} ignored: {held}"
        task_record(task, old=task.status, at=beat.now, note=note, **why)
        return
    acknowledged = task.status == TaskStatus.ASSIGNED
    if acknowledged:  # the robot has it, whether or not its ack of the plan arrived
        _acknowledge(beat, task, note=event.type, **why)
    moved = _HANDLERS[event.type](beat, task, event, why)
    if not (moved or acknowledged):
        task_record(task, old=task.status, at=beat.now, note=event.type, **why)


def _loaded(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    if not _stop_done(beat, task, event):
        return False
    if any(s.is_remaining for s in task.stops.all() if s.action == StopAction.PICKUP):
        return False
    if task.status == TaskStatus.PICKED_UP:  # a return trip whose pick-ups were dropped
        return False
    task.picked_up_at = beat.now
    task_move(task, TaskStatus.PICKED_UP, at=beat.now, fields=["picked_up_at"], **why)
    return True


def _unloaded(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    if not _stop_done(beat, task, event):
        return False
    if any(s.is_remaining for s in task.stops.all() if s.action == StopAction.DROPOFF):
        return False
    if task.return_trip:
        task.cancelled_at = beat.now
        task_move(task, TaskStatus.CANCELLED, at=beat.now, fields=["cancelled_at"], **why)
    else:
        task.delivered_at = beat.now
        task_move(task, TaskStatus.DELIVERED, at=beat.now, fields=["delivered_at"], **why)
    beat.finished = True
    return True


def _stop_done(beat: _Heartbeat, task: Task, event: RobotEvent) -> bool:
    """Mark the event's stop done; False if it already was, or was dropped from the task."""
    stop = _stop(task, event.stop)
    if not stop.is_remaining:
        return False
    stop.done_at, stop.done_by = beat.now, event
    stop.save(update_fields=["done_at", "done_by"])
    return True


def _completed(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    if task.return_trip:
        task.cancelled_at = task.cancelled_at or beat.now
        task_move(task, TaskStatus.CANCELLED, at=beat.now, fields=["cancelled_at"], **why)
    else:
        task.completed_at = beat.now
        task_move(task, TaskStatus.COMPLETED, at=beat.now, fields=["completed_at"], **why)
    beat.finished = True
    return True


def _failed(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    task.failed_at, task.eta = beat.now, None
    reason = str(event.data.get("reason") or event.data.get("error") or "")[:200]
    task_move(task, TaskStatus.FAILED, at=beat.now, fields=["failed_at", "eta"], note=reason, **why)
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.TASK_FAILED,
        key=f"task-failed:{task.code}",
        message=f"{task.code} ({task.contents}) failed on {beat.robot.code}"
        + (f": {reason}" if reason else ""),
        robot=beat.robot,
        task=task.code,
    )
    beat.failed = True
    return True


def _noted(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    return False  # task_received (acknowledges, above) and arrived: history only


_HANDLERS = {
    EventType.TASK_RECEIVED: _noted,
    EventType.ARRIVED: _noted,
    EventType.LOADED: _loaded,
    EventType.UNLOADED: _unloaded,
    EventType.TASK_COMPLETED: _completed,
    EventType.TASK_FAILED: _failed,
}


def _replan_if_needed(beat: _Heartbeat) -> None:
    """A failed task leaves the robot's plan; a robot with nothing left goes to its dock."""
    if beat.failed:
        robot_replan(robot=beat.robot, now=beat.now)
    elif beat.finished:
        robot_dock_if_idle(robot=beat.robot, now=beat.now)
