"""The chain of custody of secure deliveries: each hand-off a robot reports is stored
(scheduling.models.CustodyEntry) and told in the task's history in plain words; a compartment
kept locked after wrong PINs alerts operators.

Called from scheduling.services.events inside the heartbeat's transaction (robot row locked).
"""

from datetime import datetime

from boards.choices import OpenedWith
from boards.models import RobotEvent
from robots.alerts import alert_raise
from robots.mapcache import waypoint_by_id
from robots.models import AlertKind, Robot
from scheduling.models import CustodyEntry, CustodyKind, Task, TaskStop

CUSTODY_FIELDS = ("compartment", "opened_with", "opened_by", "failed_attempts")


def reports_custody(task: Task, event: RobotEvent) -> bool:
    """Whether the event is a hand-off to keep: of a secure delivery, or naming a compartment."""
    return task.secure or any(name in event.data for name in CUSTODY_FIELDS)


def custody_record(
    *, task: Task, stop: TaskStop | None, event: RobotEvent, robot: Robot, at: datetime, kind: str
) -> CustodyEntry:
    data = event.data
    station = waypoint_by_id(robot.site, stop.waypoint_id) if stop is not None else None
    return CustodyEntry.objects.create(
        task=task,
        kind=kind,
        at=at,
        robot=robot,
        station=station.label if station else "",
        compartment=data.get("compartment", ""),
        opened_with=data.get("opened_with", ""),
        opened_by=data.get("opened_by", ""),
        failed_attempts=data.get("failed_attempts", 0),
        event=event,
    )


def custody_words(entry: CustodyEntry) -> str:
    """A hand-off in the words of the task's history."""
    compartment = f"compartment {entry.compartment}" if entry.compartment else "the robot"
    who = f" ({entry.opened_by})" if entry.opened_by else ""
    wrong = _wrong(entry.failed_attempts)
    if entry.kind == CustodyKind.LOADED:
        return f"Loaded into {compartment} at {entry.station or 'the pick-up'}{who}"
    if entry.kind == CustodyKind.MOVED_ON:
        where = entry.station or "the drop-off"
        return f"Taken away from {where} in {compartment}: nobody unloaded it"
    if entry.kind == CustodyKind.LOCKED_OUT:
        where = entry.station or "the drop-off"
        return f"{compartment[0].upper()}{compartment[1:]} kept locked at {where}{wrong}"
    how = f", opened with {OpenedWith(entry.opened_with).label}" if entry.opened_with else ""
    return f"Handed over at {entry.station or 'the drop-off'} from {compartment}{how}{who}{wrong}"


def _wrong(attempts: int) -> str:
    if not attempts:
        return ""
    return f" after {attempts} wrong PIN{'s' if attempts != 1 else ''}"


def lockout_alert(*, task: Task, entry: CustodyEntry, robot: Robot) -> None:
    alert_raise(
        site_id=task.site_id,
        kind=AlertKind.COMPARTMENT_LOCKED,
        key=f"locked-out:{task.code}",
        message=f"{robot.code}: {custody_words(entry)} ({task.code}, {task.contents}). "
        "The items stay locked on board: check who tried, then cancel it to bring them back.",
        robot=robot,
        task=task.code,
    )
