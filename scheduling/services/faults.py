"""Robot faults and events that do not fit: operators are told once, tasks move at most once.

* A robot that reports a fault (status `error`, or a non-empty `errors` list) is held: it gets
  no new task, the tasks it has not picked up are given back to the scheduler once, and one
  operator alert lists what it still carries. The hold ends when an operator resolves it
  (Resume, or Return to dock: scheduling.services.operator), which also closes the alert.
* An event that does not fit its task's state (scheduling.services.events decides) never moves
  the task: it is recorded in the task's history as an anomaly and operators are alerted, once
  per task while the alert is open.

Both run inside the heartbeat's transaction with the robot's row locked.
"""

from datetime import datetime

from django.utils import timezone
from django.utils.translation import gettext_noop

from boards.models import RobotEvent
from boards.services import AppliedHeartbeat
from core.said import Said
from robots.alerts import alert_raise, alerts_close
from robots.choices import RobotStatus
from robots.models import AlertKind, Robot
from robots.services import robot_publish
from scheduling.choices import Cause
from scheduling.models import Task
from scheduling.services.history import task_record
from scheduling.services.presence import give_back_unloaded


def robot_fault_key(robot: Robot) -> str:
    return f"robot-error:{robot.code}"


def is_faulty(robot: Robot) -> bool:
    """Whether the robot's last applied state reports a fault."""
    return robot.status == RobotStatus.ERROR or bool(robot.errors)


def heartbeat_fault_check(*, applied: AppliedHeartbeat) -> None:
    """Hold a robot whose fresh heartbeat first reports a fault (no query otherwise)."""
    robot = applied.robot
    if applied.state_applied and robot.fault_at is None and is_faulty(robot):
        robot_fault(robot=robot, at=applied.now)


def robot_fault(*, robot: Robot, at: datetime) -> int:
    """Hold the robot after a fault, give back what it has not picked up, alert operators.

    Call with the robot's row locked; does nothing if it is already held for a fault, so a
    robot repeating its error in every heartbeat changes nothing more. Returns how many tasks
    were given back.
    """
    if robot.fault_at is not None:
        return 0
    robot.fault_at = at
    robot.save(update_fields=["fault_at"])
    what = "; ".join(robot.errors or []) or "no reason given"
    reason = Said(
        gettext_noop("%(robot)s reported a fault (%(what)s)"), robot=robot.code, what=what[:120]
    )
    given_back, loaded = give_back_unloaded(robot, at, reason=reason, cause=Cause.ROBOT_FAULT)
    _alert_fault(robot, what, given_back, loaded)
    note = Said(
        gettext_noop("%(reason)s: the items stay on board until an operator sees to it"),
        reason=reason,
    )
    for task in loaded:
        task_record(task, old=task.status, at=at, cause=Cause.ROBOT_FAULT, robot=robot, note=note)
    robot_publish(robot=robot)
    return len(given_back)


def _alert_fault(robot: Robot, what: str, given_back: list[Task], loaded: list[Task]) -> None:
    said = {"robot": robot.code, "what": what[:500]}
    given, kept = _listed(given_back)[:200], _listed(loaded)[:200]
    if given_back and loaded:
        message = Said(FAULT_GIVEN_AND_KEPT, **said, given=given, kept=kept)
    elif given_back:
        message = Said(FAULT_GIVEN, **said, given=given)
    elif loaded:
        message = Said(FAULT_KEPT, **said, kept=kept)
    else:
        message = Said(FAULT, **said)
    alert_raise(
        site_id=robot.site_id,
        kind=AlertKind.ROBOT_ERROR,
        key=robot_fault_key(robot),
        message=message,
        robot=robot,
        task=loaded[0].code if loaded else "",
    )


FAULT = gettext_noop("%(robot)s reports an error: %(what)s.")
FAULT_GIVEN = gettext_noop(
    "%(robot)s reports an error: %(what)s. Given to other robots: %(given)s."
)
FAULT_KEPT = gettext_noop(
    "%(robot)s reports an error: %(what)s. Still on board: %(kept)s. "
    "Resume it or send it to its dock."
)
FAULT_GIVEN_AND_KEPT = gettext_noop(
    "%(robot)s reports an error: %(what)s. Given to other robots: %(given)s. "
    "Still on board: %(kept)s. Resume it or send it to its dock."
)


def _listed(tasks: list[Task]) -> str:
    return ", ".join(f"{task.code} ({task.contents})" for task in tasks)


def robot_fault_resolve(*, robot: Robot, by, at: datetime | None = None) -> bool:
    """An operator resolved the robot's fault (Resume or Return to dock); False if none.

    Call with the robot's row locked. Its fault alert is closed, acknowledged by `by`.
    """
    if robot.fault_at is None:
        return False
    robot.fault_at = None
    robot.save(update_fields=["fault_at"])
    alerts_close(key=robot_fault_key(robot), by=by, at=at or timezone.now())
    return True


def event_anomaly_record(
    *, task: Task, event: RobotEvent, robot: Robot, at: datetime, why: str
) -> None:
    """Record an event that does not fit the task in its history, and alert operators."""
    note = f"{why}: ignored"
    task_record(
        task, old=task.status, at=at, cause=Cause.ANOMALY, robot=robot, event=event, note=note
    )
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.EVENT_ANOMALY,
        key=f"event-anomaly:{task.code}",
        message=f"{task.code} ({task.contents}): {why}. The delivery was left as it was "
        f"({task.get_status_display().lower()}); check where its items are.",
        robot=robot,
        task=task.code,
    )
