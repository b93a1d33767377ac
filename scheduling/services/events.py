"""Robot events and plan acknowledgements drive the task lifecycle (heartbeat_applied).

Runs inside the heartbeat's transaction with the robot row locked; plans posted here go out
in the same response. Unknown task codes and stops refuse the whole heartbeat (400).
"""

from dataclasses import dataclass, field
from datetime import datetime

from django.utils.translation import gettext_noop

from boards.choices import EventType, MessageType
from boards.models import BoardMessage, RobotEvent
from boards.services import AppliedHeartbeat, HeartbeatRejected
from core.said import Said, in_english
from robots.alerts import alert_raise
from robots.models import AlertKind, Robot
from scheduling.choices import (
    HELD_STATUSES,
    WAITING_STATUSES,
    Cause,
    StopAction,
    TaskStatus,
)
from scheduling.models import CustodyKind, Task, TaskStop
from scheduling.services.custody import (
    custody_record,
    custody_words,
    lockout_alert,
    reports_custody,
)
from scheduling.services.faults import event_anomaly_record
from scheduling.services.history import task_move, task_moves_held, task_moves_write, task_record
from scheduling.services.plans import robot_dock_if_idle, robot_replan
from scheduling.services.presence import task_give_back

TASK_EVENTS = {
    EventType.TASK_RECEIVED,
    EventType.ARRIVED,
    EventType.LOADED,
    EventType.UNLOADED,
    EventType.TASK_COMPLETED,
    EventType.TASK_FAILED,
    EventType.COMPARTMENT_LOCKED,
}
STOP_ACTIONS = {EventType.LOADED: StopAction.PICKUP, EventType.UNLOADED: StopAction.DROPOFF}


@dataclass
class _Heartbeat:
    robot: Robot
    now: datetime
    tasks: dict[str, Task]
    failed: bool = False
    finished: bool = False
    # (reason, task, outcome) of each task_failed: one alert per reason (a refused order)
    failures: list[tuple[str, Task, Said]] = field(default_factory=list)


def heartbeat_tasks_apply(*, applied: AppliedHeartbeat) -> None:
    """Apply the heartbeat's plan acks, then its new task events, in order."""
    plans = [message for message in applied.acked if message.type == MessageType.PLAN]
    events = [
        (applied.event_index.get(event.event_id, n), event)
        for n, event in enumerate(applied.events)
        if event.type in TASK_EVENTS and (event.task or event.type != EventType.ARRIVED)
    ]
    codes = {event.task for _, event in events} | {c for m in plans for c in _plan_tasks(m)}
    if not codes and not events:
        return  # the common heartbeat, or the ack of a plan without tasks (to its dock)
    beat = _Heartbeat(applied.robot, applied.now, _tasks(applied.robot, codes))
    _check(events, beat.tasks)
    with task_moves_held():  # a delivery reported at once moves its task four times
        for message in plans:
            _plan_acked(beat, message)
        for _, event in events:
            _event_apply(beat, event)
    _failures_alert(beat)
    _replan_if_needed(beat)


def _plan_tasks(message: BoardMessage) -> list[str]:
    tasks = message.body.get("tasks")
    return list(tasks) if isinstance(tasks, dict) else []


def _tasks(robot: Robot, codes) -> dict[str, Task]:
    """The tasks of the site with these codes, each with its stops."""
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
            note = Said(gettext_noop("%(robot)s has it in its plan"), robot=beat.robot.code)
            _acknowledge(beat, task, cause=Cause.ROBOT_ACK, robot=beat.robot, note=note)


def _acknowledge(beat: _Heartbeat, task: Task, **why) -> None:
    task.acknowledged_at, task.ack_due_at = beat.now, None
    fields = ["acknowledged_at", "ack_due_at"]
    task_move(task, TaskStatus.ACKNOWLEDGED, at=beat.now, fields=fields, **why)


def _event_apply(beat: _Heartbeat, event: RobotEvent) -> None:
    task = beat.tasks[event.task]
    why = {"cause": Cause.ROBOT_EVENT, "robot": beat.robot, "event": event}
    misfit = _misfit(beat, task, event)
    if misfit:
        event_anomaly_record(task=task, event=event, robot=beat.robot, at=beat.now, why=misfit)
        return
    if not _holds(beat, task):
        task_record(task, old=task.status, at=beat.now, note=_not_held(beat, task, event), **why)
        return
    acknowledged = task.status == TaskStatus.ASSIGNED
    if acknowledged:  # the robot has it, whether or not its ack of the plan arrived
        _acknowledge(beat, task, note=event.type, **why)
    moved = _HANDLERS[event.type](beat, task, event, why)
    if not (moved or acknowledged):
        why.setdefault("note", event.type)
        task_record(task, old=task.status, at=beat.now, **why)


def _not_held(beat: _Heartbeat, task: Task, event: RobotEvent) -> str:
    """The history's note for an event about a task the robot no longer holds."""
    if task.robot_id != beat.robot.pk:
        return f"{event.type} from {beat.robot.code} ignored: not its task"
    if event.type == EventType.TASK_COMPLETED and task.return_trip:
        # The protocol asks for task_completed once the items are back: expected, not ignored.
        return f"{beat.robot.code} finished its trip back with the items"
    return f"{event.type} from {beat.robot.code} ignored: the task is {task.get_status_display()}"


def _misfit(beat: _Heartbeat, task: Task, event: RobotEvent) -> str:
    """Why the event does not fit the task's state, in plain words; "" if it does.

    Items moved for a task the robot does not hold, items taken off before all were loaded,
    or a task completed before its last drop-off: the robot and the server disagree about
    where the items are, which a person must sort out. Such an event never moves the task.
    """
    if not _holds(beat, task):
        if event.type in STOP_ACTIONS:
            return f"{beat.robot.code} reported {event.type} for a delivery {_whose(beat, task)}"
        return ""
    stops = task.stops.all()
    if event.type == EventType.UNLOADED and any(
        s.is_remaining for s in stops if s.action == StopAction.PICKUP
    ):
        return f"{beat.robot.code} reported unloaded before everything was loaded"
    if event.type == EventType.TASK_COMPLETED and task.status != TaskStatus.DELIVERED:
        if task.status == TaskStatus.PICKED_UP:
            return f"{beat.robot.code} reported it completed before its last drop-off"
        return f"{beat.robot.code} reported it completed before it was picked up"
    return ""


def _whose(beat: _Heartbeat, task: Task) -> str:
    if task.robot_id is not None and task.robot_id != beat.robot.pk:
        return "that is another robot's"
    if task.status in WAITING_STATUSES:
        return "waiting for a robot"
    return f"that is {task.get_status_display().lower()}"


def _custody(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict, kind: str) -> None:
    """Keep the hand-off of a secure delivery (or one naming a compartment), in plain words
    in the history entry of this event (why["note"])."""
    if reports_custody(task, event):
        stop = _stop(task, event.stop)
        entry = custody_record(
            task=task, stop=stop, event=event, robot=beat.robot, at=beat.now, kind=kind
        )
        why["note"] = custody_words(entry)


def _loaded(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    if not _stop_done(beat, task, event):
        return False
    _custody(beat, task, event, why, CustodyKind.LOADED)
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
    _custody(beat, task, event, why, CustodyKind.UNLOADED)
    if any(s.is_remaining for s in task.stops.all() if s.action == StopAction.DROPOFF):
        return False
    if task.return_trip:
        _returned(beat, task, why)
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


def _returned(beat: _Heartbeat, task: Task, why: dict) -> None:
    """A return trip ends cancelled, or failed if nobody unloaded it at its drop-off."""
    if task.unattended_at is not None:
        task.failed_at, task.eta = task.failed_at or beat.now, None
        task_move(task, TaskStatus.FAILED, at=beat.now, fields=["failed_at", "eta"], **why)
    else:
        task.cancelled_at = task.cancelled_at or beat.now
        task_move(task, TaskStatus.CANCELLED, at=beat.now, fields=["cancelled_at"], **why)


def _completed(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    if task.return_trip:
        _returned(beat, task, why)
    else:
        task.completed_at = beat.now
        task_move(task, TaskStatus.COMPLETED, at=beat.now, fields=["completed_at"], **why)
    beat.finished = True
    return True


def _failed(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    """A task the robot cannot carry out: with nothing on board it goes to another robot,
    once; a second failure, or one with items on board, ends it. Operators are told either way.
    """
    reason = str(event.data.get("reason") or event.data.get("error") or "")[:200]
    because = f": {reason}" if reason else ""
    if not _loaded_any(task) and not _failed_before(task):
        note = Said(
            gettext_noop("%(robot)s could not do it%(because)s"),
            robot=beat.robot.code,
            because=because,
        )
        task_give_back(
            task, beat.robot, beat.now, avoid=True, cause=Cause.ROBOT_FAULT, event=event, note=note
        )
        outcome = Said(gettext_noop("given to another robot"))
    else:
        task.failed_at, task.eta = beat.now, None
        fields = ["failed_at", "eta"]
        task_move(task, TaskStatus.FAILED, at=beat.now, fields=fields, note=reason, **why)
        outcome = Said(
            gettext_noop("items still on board")
            if _loaded_any(task)
            else gettext_noop("it had failed before")
        )
    beat.failures.append((reason, task, outcome))
    beat.failed = True
    return True


def _failures_alert(beat: _Heartbeat) -> None:
    """One alert per reason: tasks failed together for one cause (a vehicle refusing an order
    of several) are one thing for the operators to see, not one alert each."""
    by_reason: dict[str, list[tuple[Task, str]]] = {}
    for reason, task, outcome in beat.failures:
        by_reason.setdefault(reason, []).append((task, outcome))
    for reason, failed in by_reason.items():
        because = f": {reason}" if reason else ""
        tasks = ", ".join(f"{task.code} ({task.contents})" for task, _ in failed)
        outcomes = {outcome for _, outcome in failed}
        if len(outcomes) == 1:
            outcome = outcomes.pop()
        else:
            outcome = "; ".join(f"{task.code}: {in_english(outcome)}" for task, outcome in failed)
        first = failed[0][0]
        codes = "+".join(task.code for task, _ in failed)
        alert_raise(
            site_id=first.site_id,
            kind=AlertKind.TASK_FAILED,
            key=f"task-failed:{codes}"[:200],
            message=Said(
                gettext_noop("%(tasks)s failed on %(robot)s%(because)s (%(outcome)s)"),
                tasks=tasks,
                robot=beat.robot.code,
                because=because,
                outcome=outcome,
            ),
            robot=beat.robot,
            task=first.code,
        )


def _loaded_any(task: Task) -> bool:
    return any(stop.done_at for stop in task.stops.all())


def _failed_before(task: Task) -> bool:
    """Whether a robot already gave the task back as failed: it is not handed round forever."""
    task_moves_write()  # the history this heartbeat has added so far, too
    return task.history.filter(
        cause=Cause.ROBOT_FAULT, new=TaskStatus.DUE, event__isnull=False
    ).exists()


def _locked(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    """Wrong PINs: the robot keeps the compartment locked; the items stay on board."""
    kind = CustodyKind.LOCKED_OUT
    stop = _stop(task, event.stop)
    entry = custody_record(
        task=task, stop=stop, event=event, robot=beat.robot, at=beat.now, kind=kind
    )
    why["note"] = f"{custody_words(entry)}: operators are alerted"
    lockout_alert(task=task, entry=entry, robot=beat.robot)
    return False


def _noted(beat: _Heartbeat, task: Task, event: RobotEvent, why: dict) -> bool:
    return False  # task_received (acknowledges, above) and arrived: history only


_HANDLERS = {
    EventType.TASK_RECEIVED: _noted,
    EventType.ARRIVED: _noted,
    EventType.LOADED: _loaded,
    EventType.UNLOADED: _unloaded,
    EventType.TASK_COMPLETED: _completed,
    EventType.TASK_FAILED: _failed,
    EventType.COMPARTMENT_LOCKED: _locked,
}


def _replan_if_needed(beat: _Heartbeat) -> None:
    """A failed task leaves the robot's plan; a robot with nothing left goes to its dock."""
    if beat.failed:
        robot_replan(robot=beat.robot, now=beat.now)
    elif beat.finished:
        robot_dock_if_idle(robot=beat.robot, now=beat.now)
