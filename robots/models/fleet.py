"""Robots: identity, credentials, the last state they reported and their presence."""

from datetime import datetime, timedelta

from django.core.validators import RegexValidator
from django.db import models
from django.db.models import Q
from django.utils import timezone
from django.utils.translation import gettext_lazy as _

from core.tokens import token_hash
from robots.choices import Presence, RobotProtocol, RobotStatus
from robots.models.map import Floor, Site, Waypoint

ROBOT_CODE = RegexValidator(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,31}$", "letters, digits, _ . -")
# Protocol v1: a robot is online while heartbeats arrive within this many intervals.
ONLINE_INTERVALS = 3


class RobotQuerySet(models.QuerySet):
    def with_token(self, token: str):
        return self.filter(token_hash=token_hash(token))


class Robot(models.Model):
    site = models.ForeignKey(Site, on_delete=models.PROTECT, related_name="robots")
    code = models.CharField(max_length=32, unique=True, validators=[ROBOT_CODE])
    name = models.CharField(max_length=200, blank=True)
    dock = models.ForeignKey(Waypoint, on_delete=models.PROTECT, related_name="docked_robots")
    capacity = models.PositiveSmallIntegerField(default=4, help_text="items it can carry")
    # Deliveries the allocator has given it: among robots equally good for a task the one given
    # fewer takes it, so wear spreads over a fleet that mostly waits at its docks.
    tasks_given = models.PositiveIntegerField(default=0, editable=False)
    # From the site file: [{"code": "A", "lockable": true}, ...], one item each (so capacity is
    # their number). Secure deliveries go only to robots with a lockable one.
    compartments = models.JSONField(default=list, blank=True)
    # Heartbeat robots call the server themselves; VDA 5050 vehicles speak MQTT to the vda5050
    # bridge, which finds them by manufacturer and serial number (its topics name both).
    protocol = models.CharField(
        max_length=16, choices=RobotProtocol, default=RobotProtocol.HEARTBEAT
    )
    manufacturer = models.CharField(max_length=64, blank=True, help_text="VDA 5050 only")
    serial_number = models.CharField(max_length=64, blank=True, help_text="VDA 5050 only")
    # The site file's `vda5050` mapping (sitefile.VDA5050_FIELDS): pick/drop parameters, per
    # station too, the vehicle's state interval and its quirks; the bridge reads it.
    vda5050 = models.JSONField(default=dict, blank=True, help_text="VDA 5050 only")
    # The vehicle's own last `factsheet` message (VDA 5050 2.0): the actions it can do and
    # their parameters, its speed; the bridge checks each order against it.
    vda5050_factsheet = models.JSONField(default=dict, blank=True, help_text="VDA 5050 only")
    token_hash = models.CharField(max_length=64, blank=True, editable=False)
    token_issued_at = models.DateTimeField(null=True, blank=True, editable=False)

    # Last state the robot reported (the newest heartbeat by boot_id + seq).
    status = models.CharField(max_length=20, choices=RobotStatus, default=RobotStatus.UNKNOWN)
    floor = models.ForeignKey(Floor, null=True, blank=True, on_delete=models.SET_NULL)
    waypoint = models.ForeignKey(
        Waypoint, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    x = models.FloatField(null=True, blank=True)
    y = models.FloatField(null=True, blank=True)
    heading = models.FloatField(null=True, blank=True)
    battery = models.FloatField(null=True, blank=True)
    load = models.PositiveSmallIntegerField(default=0)
    plan_version = models.PositiveIntegerField(default=0, help_text="newest plan it applied")
    errors = models.JSONField(default=list, blank=True)
    reported_at = models.DateTimeField(null=True, blank=True)
    boot_id = models.CharField(max_length=64, blank=True)
    seq = models.BigIntegerField(null=True, blank=True)

    # Presence: the stored value is what the last heartbeat or sweep recorded; the deadlines
    # say when it changes next, so the sweep only touches rows whose deadline has passed.
    presence = models.CharField(max_length=12, choices=Presence, default=Presence.OFFLINE)
    last_seen_at = models.DateTimeField(null=True, blank=True)
    unreachable_at = models.DateTimeField(null=True, blank=True)
    offline_at = models.DateTimeField(null=True, blank=True)
    # The heartbeat interval the load asked of this robot at its last heartbeat (seconds, 0:
    # none yet), from which the next is judged (core/overload.py).
    heartbeat_interval_told = models.FloatField(default=0.0)

    # Set by an operator's Pause or Return to dock, cleared by Resume (scheduling.services
    # .operator):
    # the scheduler offers the robot no new task meanwhile, whatever it reports.
    paused_by_operator = models.BooleanField(
        default=False, help_text="held by an operator: no new tasks until resumed"
    )
    # Set when the robot first reports a fault (status `error` or a non-empty `errors`), by
    # scheduling.services.faults, which gives back its tasks then, once; cleared when an
    # operator resolves it (Resume, or Return to dock). No new tasks meanwhile.
    fault_at = models.DateTimeField(
        null=True,
        blank=True,
        help_text="reported a fault: no new tasks until an operator resolves it",
    )

    # Set when the scheduler sends it to charge (scheduling.services.charging), cleared once its
    # battery reaches the site's battery_charged: no new tasks meanwhile.
    sent_to_charge = models.BooleanField(
        default=False, help_text="sent to its dock to charge: no new tasks until charged"
    )

    # Set when an operator takes the robot out of service for maintenance, cleared when an
    # operator returns it or maintenance_until passes (scheduling.services.maintenance): no
    # new tasks meanwhile, whatever it reports.
    maintenance_since = models.DateTimeField(
        null=True, blank=True, help_text="in maintenance: no new tasks until returned to service"
    )
    maintenance_until = models.DateTimeField(
        null=True, blank=True, help_text="returned to service at this time, if set"
    )
    maintenance_reason = models.CharField(max_length=200, blank=True)

    # When it last made progress: moved (another floor, waypoint, or metre of x or y) or
    # reported anything but `moving`. A robot `moving` without progress for its site's
    # stuck_timeout is stuck (scheduling.services.stuck): stuck_since is set once, by the
    # sweep that alerts the operators, and cleared by its next progress.
    progress_at = models.DateTimeField(null=True, blank=True)
    stuck_since = models.DateTimeField(
        null=True, blank=True, help_text="moving without progress: operators alerted"
    )

    # Learned from the robot's own events (scheduling.services.etas), for its ETAs.
    pace_travel = models.FloatField(
        null=True, blank=True, help_text="its travel times over the map's estimates, as observed"
    )
    pace_dwell = models.FloatField(
        null=True, blank=True, help_text="seconds it spends at a stop, as observed"
    )

    objects = RobotQuerySet.as_manager()

    # Written by each fresh heartbeat, and by each heartbeat or sweep, respectively.
    STATE_FIELDS = [
        "status",
        "floor",
        "waypoint",
        "x",
        "y",
        "heading",
        "battery",
        "load",
        "plan_version",
        "errors",
        "reported_at",
        "progress_at",
        "stuck_since",
    ]
    PRESENCE_FIELDS = ["presence", "last_seen_at", "unreachable_at", "offline_at"]

    class Meta:
        ordering = ["code"]
        constraints = [
            models.UniqueConstraint(
                fields=["token_hash"], condition=~Q(token_hash=""), name="robot_token_unique"
            ),
            models.UniqueConstraint(
                fields=["manufacturer", "serial_number"],
                condition=~Q(serial_number=""),
                name="robot_vda5050_identity_unique",
            ),
        ]
        # No index on the deadlines (unreachable_at, offline_at), although the presence sweep
        # filters on them: every heartbeat moves them, and a changed indexed column makes
        # PostgreSQL write a new entry in each of the table's indexes instead of updating the
        # row in place (a HOT update), and a heartbeat's UPDATE writes about a quarter of the
        # WAL it would with them; the sweep reads the robots table, a few hundred rows, once a
        # second.

    def __str__(self):
        return self.code

    @property
    def lockable_compartments(self) -> list[str]:
        """Compartments that open for the recipient's PIN only. None on a VDA 5050 vehicle:
        the standard has no way to hand it a PIN, so secure deliveries go to other robots."""
        if self.protocol == RobotProtocol.VDA5050:
            return []
        return [c["code"] for c in self.compartments or () if c.get("lockable")]

    def presence_at(self, now: datetime) -> str:
        """Presence as a pure function of the stored times (protocol v1, "Presence")."""
        if self.last_seen_at is None:
            return Presence.OFFLINE
        if now < self.unreachable_at:
            return Presence.ONLINE
        if now < self.offline_at:
            return Presence.UNREACHABLE
        return Presence.OFFLINE

    def mark_seen(
        self, now: datetime, interval: float | None = None, waited: float = 0.0
    ) -> str | None:
        """Record a heartbeat at `now`, answered with `interval` (seconds until the next; the
        site's if not given) after it `waited` seconds for a web worker; returns the previous
        presence if this changed it.

        The deadlines follow the interval the robot was told, so a robot told to wait longer
        (core/overload.py) is not flipped for obeying; and they are later by the wait, since
        its next heartbeat may wait as long in the server's queue, where the server is late,
        not the robot (protocol v1, "Presence")."""
        previous = self.presence
        online_for = ONLINE_INTERVALS * (interval or self.site.heartbeat_interval) + waited
        self.last_seen_at = now
        self.unreachable_at = now + timedelta(seconds=online_for)
        self.offline_at = now + timedelta(seconds=max(self.site.offline_timeout, online_for))
        self.presence = Presence.ONLINE
        return previous if previous != Presence.ONLINE else None

    def apply_state(self, state: dict, now: datetime) -> None:
        """Store a validated heartbeat `state` (floor and waypoint resolved to ids)."""
        if self._progresses(state):
            self.progress_at, self.stuck_since = now, None
        self.status = state["status"]
        self.floor_id = state["floor_id"]
        self.waypoint_id = state.get("waypoint_id")
        self.x = state.get("x")
        self.y = state.get("y")
        self.heading = state.get("heading")
        self.battery = state["battery"]
        self.load = state["load"]
        self.plan_version = state["plan_version"]
        self.errors = state.get("errors", [])
        self.reported_at = now

    def _progresses(self, state: dict) -> bool:
        """Whether `state` is progress over the stored one: it is not `moving` (nor was), or
        it is elsewhere: whole metres, so a stuck robot's sensor noise is no progress."""
        if state["status"] != RobotStatus.MOVING or self.status != RobotStatus.MOVING:
            return True
        where = (
            state["floor_id"],
            state.get("waypoint_id"),
            *_metres(state.get("x"), state.get("y")),
        )
        return where != (self.floor_id, self.waypoint_id, *_metres(self.x, self.y))


def _metres(*values: float | None) -> tuple:
    return tuple(None if value is None else round(value) for value in values)


class RobotBoot(models.Model):
    """Every boot_id a robot has used: a heartbeat from an earlier boot is stale, not new."""

    robot = models.ForeignKey(Robot, on_delete=models.CASCADE, related_name="boots")
    boot_id = models.CharField(max_length=64)
    first_seen_at = models.DateTimeField(default=timezone.now)

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["robot", "boot_id"], name="robot_boot_unique"),
        ]

    def __str__(self):
        return f"{self.robot.code} boot {self.boot_id}"


class PresenceChange(models.Model):
    """One flip of a robot's presence, by a heartbeat or by the sweep."""

    class Cause(models.TextChoices):
        HEARTBEAT = "heartbeat", _("Heartbeat")
        SWEEP = "sweep", _("Sweep (deadline passed)")
        CONNECTION = "connection", _("Connection lost (VDA 5050 last will or goodbye)")

    robot = models.ForeignKey(Robot, on_delete=models.CASCADE, related_name="presence_changes")
    at = models.DateTimeField()
    old = models.CharField(max_length=12, choices=Presence)
    new = models.CharField(max_length=12, choices=Presence)
    cause = models.CharField(max_length=12, choices=Cause)

    class Meta:
        ordering = ["-at", "-id"]
        indexes = [models.Index(fields=["robot", "-at"], name="presence_change_recent")]

    def __str__(self):
        return f"{self.robot.code}: {self.old} -> {self.new} at {self.at:%Y-%m-%d %H:%M:%S}"


class RobotActivity(models.Model):
    """What a robot was doing from `at` until its next row: its reported status while online,
    else its presence ("unreachable", "offline"). Written only when that changes (a heartbeat
    reporting another status, a presence flip), for the reports' utilisation."""

    robot = models.ForeignKey(Robot, on_delete=models.CASCADE, related_name="activities")
    at = models.DateTimeField()
    activity = models.CharField(max_length=20)

    class Meta:
        ordering = ["robot", "at", "id"]
        indexes = [models.Index(fields=["robot", "at"], name="robot_activity_at")]

    def __str__(self):
        return f"{self.robot_id}: {self.activity} from {self.at:%Y-%m-%d %H:%M:%S}"


def robot_activity(robot: Robot) -> str:
    """The activity a robot's stored state amounts to (RobotActivity.activity)."""
    return robot.status if robot.presence == Presence.ONLINE else robot.presence
