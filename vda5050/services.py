"""What the VDA 5050 bridge reads and writes. Writes go through the services a heartbeat
robot's requests go through: a vehicle's state is a heartbeat (boards.services.heartbeat_apply,
with the robot's row locked, so every rule and every hook runs as for a heartbeat robot), its
lost connection a presence flip (robots.services.robot_connection_lost)."""

from dataclasses import dataclass

from django.conf import settings
from django.db import transaction
from django.utils.translation import gettext_noop
from rest_framework.exceptions import ValidationError

from boards.protocol import message_wire
from boards.serializers import heartbeat_validate
from boards.services import HeartbeatRejected, heartbeat_apply
from core.errors import flatten_errors
from core.said import Said
from robots.alerts import alert_raise, alerts_close
from robots.choices import RobotProtocol
from robots.mapcache import router_for, site_map
from robots.models import AlertKind, Robot
from robots.router import Router, SiteMap
from robots.services import robot_connection_lost, robot_lock
from scheduling.models import RobotPlan, TaskStop, task_pk


@dataclass(frozen=True)
class Vehicle:
    robot_id: int
    code: str
    dock: str
    site_map: SiteMap
    router: Router
    plan: dict | None  # the robot's current plan, stops done left out (after a restart)
    options: dict  # the site file's `vda5050` mapping of the robot
    lifts_by_car: bool  # the building drives the lifts and reports where their cars are
    factsheet: dict  # the vehicle's last factsheet, stored ({} if it never sent one)


class HeartbeatRefused(Exception):
    """The heartbeat a state stands for was refused; nothing of it was applied."""

    def __init__(self, errors: dict[str, list[str]]):
        super().__init__(errors)
        self.errors = errors


def vehicle_find(*, manufacturer: str, serial_number: str) -> Vehicle | None:
    """The VDA 5050 robot with this identity, with its site's map, or None."""
    robot = (
        Robot.objects.filter(
            protocol=RobotProtocol.VDA5050, manufacturer=manufacturer, serial_number=serial_number
        )
        .select_related("site", "dock")
        .first()
    )
    if robot is None:
        return None
    return Vehicle(
        robot_id=robot.pk,
        code=robot.code,
        dock=robot.dock.code,
        site_map=site_map(robot.site),
        router=router_for(robot.site),
        plan=vehicle_plan_now(robot_id=robot.pk),
        options=robot.vda5050 or {},
        lifts_by_car=settings.BUILDING_ADAPTER != "none",
        factsheet=robot.vda5050_factsheet or {},
    )


def vehicle_plan_now(*, robot_id: int) -> dict | None:
    """The last plan posted for the robot, without the stops done since: what a bridge that
    starts (or restarts) while the vehicle is out puts it back on."""
    plan = RobotPlan.objects.filter(robot_id=robot_id).first()
    if plan is None:
        return None
    done = set(
        TaskStop.objects.filter(task__robot_id=robot_id, done_at__isnull=False).values_list(
            "task_id", "index"
        )
    )
    stops = [
        stop
        for stop in plan.body["stops"]
        if "task" not in stop or (task_pk(stop["task"]), stop["stop"]) not in done
    ]
    return {"plan_version": plan.version, "stops": stops}


@transaction.atomic
def vehicle_heartbeat(*, robot_id: int, heartbeat: dict) -> list[dict]:
    """Apply the heartbeat a vehicle's state stands for; the board's messages, as robots get
    them. HeartbeatRefused (nothing applied) where a robot would get a 400."""
    robot = robot_lock(robot_id)
    try:  # the everyday body by hand, any other by the serializer, as the robots' HTTP path
        validated = heartbeat_validate(heartbeat, site_map(robot.site))
    except ValidationError as invalid:
        raise HeartbeatRefused(flatten_errors(invalid.detail)) from None
    try:
        reply = heartbeat_apply(robot=robot, heartbeat=validated)
    except HeartbeatRejected as rejected:
        raise HeartbeatRefused(flatten_errors(rejected.errors)) from None
    return [message_wire(message) for message in reply.messages]


def vehicle_connection_lost(*, robot_id: int, graceful: bool) -> str:
    return robot_connection_lost(robot_id=robot_id, graceful=graceful)


def vehicle_factsheet_store(*, robot_id: int, factsheet: dict) -> None:
    """Keep the vehicle's factsheet (operators read it; a restarted bridge checks with it)."""
    Robot.objects.filter(pk=robot_id).update(vda5050_factsheet=factsheet)


def vehicle_held_alert(*, robot_id: int, lift: str, floor: str, seconds: float) -> None:
    """One alert: the vehicle waits, granted, at a lift whose car has not come to its floor."""
    robot = Robot.objects.get(pk=robot_id)
    alert_raise(
        site_id=robot.site_id,
        kind=AlertKind.LIFT_CAR_MISSING,
        key=_held_key(robot.code, lift, floor),
        message=Said(
            gettext_noop(
                "%(robot)s has waited %(seconds)s s at %(lift)s on floor %(floor)s for a car that "
                "has not come; it stays there until the car reports that floor with its doors open"
            ),
            robot=robot.code,
            seconds=f"{seconds:.0f}",
            lift=lift,
            floor=floor,
        ),
        robot=robot,
    )


def vehicle_held_alert_close(*, robot_id: int, lift: str, floor: str) -> None:
    """The car came after all: the alert is closed (the cause is gone)."""
    code = Robot.objects.values_list("code", flat=True).get(pk=robot_id)
    alerts_close(key=_held_key(code, lift, floor))


def _held_key(robot_code: str, lift: str, floor: str) -> str:
    return f"lift-car-missing:{robot_code}:{lift}:{floor}"
