"""The building as the robots see it: floors, waypoints, edges and shared resources.

Written only by the site loader (robots/sitefile.py), which validates a whole file first.
"""

from django.core.validators import MinValueValidator
from django.db import models

from robots.choices import ResourceKind, WaypointKind
from robots.names import place_label

POSITIVE = [MinValueValidator(0.001)]
UNATTENDED_TO_PICKUP = "pickup"  # Site.unattended_return: back to the task's first pick-up


class Site(models.Model):
    code = models.SlugField(max_length=64, unique=True)
    name = models.CharField(max_length=200, blank=True)
    robot_speed = models.FloatField(
        default=1.0, validators=POSITIVE, help_text="metres per second, for every robot"
    )
    heartbeat_interval = models.FloatField(
        default=1.0, validators=POSITIVE, help_text="seconds between robot heartbeats"
    )
    ack_timeout = models.FloatField(
        default=30.0, validators=POSITIVE, help_text="seconds for a robot to acknowledge a plan"
    )
    offline_timeout = models.FloatField(
        default=300.0, validators=POSITIVE, help_text="seconds of silence before offline"
    )
    grant_timeout = models.FloatField(
        default=60.0,
        validators=POSITIVE,
        help_text="seconds a robot has to enter a resource it was granted",
    )
    lease_hard_limit = models.FloatField(
        default=900.0,
        validators=POSITIVE,
        help_text="seconds a silent robot inside a resource keeps it before operators are alerted",
    )
    unload_timeout = models.FloatField(
        default=300.0,
        validators=POSITIVE,
        help_text="seconds a robot waits at a drop-off before operators are alerted",
    )
    # After the longer unattended_timeout the robot moves on: the items stay on board (secure
    # ones locked) and go to unattended_return, the task ends failed (not delivered).
    unattended_timeout = models.FloatField(
        default=1800.0,
        validators=POSITIVE,
        help_text="seconds a robot waits at a drop-off nobody unloads before it moves on",
    )
    unattended_return = models.CharField(
        max_length=64,
        default=UNATTENDED_TO_PICKUP,
        help_text='where it then takes the items: "pickup" (back to the sender) or a station code',
    )
    stuck_timeout = models.FloatField(
        default=600.0,
        validators=POSITIVE,
        help_text="seconds a robot may report moving without progress before operators are alerted",
    )
    battery_threshold = models.FloatField(
        default=0.2, help_text="robots below this battery level get no new tasks"
    )
    stat_due_minutes = models.FloatField(
        default=20.0, validators=POSITIVE, help_text="a STAT delivery is due this long after"
    )
    urgent_due_minutes = models.FloatField(
        default=45.0, validators=POSITIVE, help_text="an urgent delivery is due this long after"
    )
    routine_due_minutes = models.FloatField(
        default=120.0, validators=POSITIVE, help_text="a routine delivery is due this long after"
    )
    battery_per_metre = models.FloatField(
        default=0.00004, help_text="battery a robot uses per metre driven (1 = a full battery)"
    )
    battery_per_ride = models.FloatField(
        default=0.001, help_text="battery a robot uses per elevator ride"
    )
    battery_reserve = models.FloatField(
        default=0.1, help_text="battery a robot must still have back at its dock after a route"
    )
    battery_charged = models.FloatField(
        default=0.8, help_text="a robot sent to charge takes tasks again from this level"
    )
    stop_dwell_seconds = models.FloatField(
        default=30.0, help_text="seconds a robot spends at a stop, until it has been observed"
    )
    map_version = models.PositiveIntegerField(
        default=1, editable=False, help_text="bumped by every load; routing caches key on it"
    )
    loaded_at = models.DateTimeField(null=True, blank=True, editable=False)
    availability_version = models.PositiveIntegerField(
        default=0,
        editable=False,
        help_text="bumped whenever a resource goes out of or back into service; routers key on "
        "it with map_version",
    )
    # Set while a fire alarm is in force (robots.models.emergency): planning is paused and no
    # elevator is granted, read from the site row the allocator and the lease controller hold.
    fire_alarm_since = models.DateTimeField(
        null=True,
        blank=True,
        editable=False,
        help_text="a fire alarm is in force: nothing is planned and no elevator is granted",
    )

    def __str__(self):
        return self.name or self.code


class Floor(models.Model):
    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="floors")
    code = models.CharField(max_length=32)
    level = models.IntegerField()
    name = models.CharField(max_length=200, blank=True)
    names = models.JSONField(
        default=dict, blank=True, help_text='its name per language code, e.g. {"ko": "..."}'
    )

    class Meta:
        ordering = ["site", "level"]
        constraints = [
            models.UniqueConstraint(fields=["site", "code"], name="floor_code_unique_in_site"),
        ]

    def __str__(self):
        return self.code


class Waypoint(models.Model):
    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="waypoints")
    floor = models.ForeignKey(Floor, on_delete=models.CASCADE, related_name="waypoints")
    code = models.CharField(max_length=64)
    name = models.CharField(max_length=200, blank=True)
    names = models.JSONField(
        default=dict, blank=True, help_text='its name per language code, e.g. {"ko": "..."}'
    )
    kind = models.CharField(max_length=16, choices=WaypointKind, default=WaypointKind.PLAIN)
    x = models.FloatField()
    y = models.FloatField()

    class Meta:
        ordering = ["site", "floor__level", "code"]
        constraints = [
            models.UniqueConstraint(fields=["site", "code"], name="waypoint_code_unique_in_site"),
        ]

    def __str__(self):
        return f"{self.name} ({self.code})" if self.name else self.code

    @property
    def label(self) -> str:
        """Its name in the viewer's language (robots/names.py), else its name, else its code."""
        return place_label(self)


class Resource(models.Model):
    """Something only `capacity` robots may use at once: an elevator, a door, a corridor."""

    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="resources")
    code = models.CharField(max_length=64)
    name = models.CharField(max_length=200, blank=True)
    names = models.JSONField(
        default=dict, blank=True, help_text='its name per language code, e.g. {"ko": "..."}'
    )
    kind = models.CharField(max_length=16, choices=ResourceKind)
    capacity = models.PositiveSmallIntegerField(default=1, validators=[MinValueValidator(1)])
    seconds_per_floor = models.FloatField(default=0.0, help_text="elevators only")
    overhead_seconds = models.FloatField(
        default=0.0, help_text="elevators only: call, doors, entering and leaving"
    )
    waypoints = models.ManyToManyField(
        Waypoint, through="ResourceWaypoint", related_name="waiting_for"
    )
    # Out of service (resources/service.py): nobody is granted it and routes avoid it where
    # another way exists. Set by an operator or by its building device's fault or silence.
    out_of_service_since = models.DateTimeField(null=True, blank=True, editable=False)
    out_of_service_reason = models.CharField(max_length=200, blank=True, editable=False)
    # Lift priority (resources/availability.py): an emergency team has the lift. Its holder
    # finishes its ride; nobody is granted it and routes avoid it until an operator ends it.
    priority_since = models.DateTimeField(null=True, blank=True, editable=False)
    priority_reason = models.CharField(max_length=200, blank=True, editable=False)

    class Meta:
        ordering = ["site", "code"]
        constraints = [
            models.UniqueConstraint(fields=["site", "code"], name="resource_code_unique_in_site"),
        ]

    def __str__(self):
        return self.code

    @property
    def is_elevator(self) -> bool:
        return self.kind == ResourceKind.ELEVATOR

    @property
    def in_service(self) -> bool:
        return self.out_of_service_since is None

    @property
    def in_priority(self) -> bool:
        return self.priority_since is not None

    @property
    def grantable(self) -> bool:
        """In service and not held for an emergency team: robots may be granted it."""
        return self.in_service and not self.in_priority

    def ride_seconds(self, from_level: int, to_level: int) -> float:
        return self.overhead_seconds + self.seconds_per_floor * abs(to_level - from_level)


class ResourceWaypoint(models.Model):
    """A waiting waypoint of a resource; for an elevator, its stop on the waypoint's floor."""

    resource = models.ForeignKey(Resource, on_delete=models.CASCADE, related_name="stops")
    waypoint = models.ForeignKey(Waypoint, on_delete=models.CASCADE, related_name="+")

    class Meta:
        constraints = [
            models.UniqueConstraint(
                fields=["resource", "waypoint"], name="resource_waypoint_unique"
            ),
        ]

    def __str__(self):
        return f"{self.resource.code} @ {self.waypoint.code}"


class Edge(models.Model):
    site = models.ForeignKey(Site, on_delete=models.CASCADE, related_name="edges")
    source = models.ForeignKey(Waypoint, on_delete=models.CASCADE, related_name="edges_out")
    target = models.ForeignKey(Waypoint, on_delete=models.CASCADE, related_name="edges_in")
    length = models.FloatField(validators=[MinValueValidator(0.0)], help_text="metres")
    oneway = models.BooleanField(default=False)
    guarded_by = models.ForeignKey(
        Resource,
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="guarded_edges",
        help_text="door or corridor whose lease a robot needs to pass this edge",
    )

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["source", "target"], name="edge_unique"),
        ]

    def __str__(self):
        arrow = "->" if self.oneway else "<->"
        return f"{self.source.code} {arrow} {self.target.code}"
