"""The heartbeat on the wire (protocol v1): request validation and response documentation."""

import math

from drf_spectacular.utils import PolymorphicProxySerializer
from rest_framework import serializers

from boards.choices import RESOURCE_EVENT_TYPES, EventType, MessageType, OpenedWith, RequestType
from core.fields import (
    StrictBooleanField,
    StrictCharField,
    StrictDateTimeField,
    StrictFloatField,
    StrictIntegerField,
)
from core.serializers import FieldsKeptPerThread
from robots.choices import REPORTABLE_STATUSES

MAX_EVENTS = 500
MAX_SEQ = 2**63 - 1


class SiteCodesMixin:
    """Checks codes against the robot's site map, passed in the serializer context."""

    @property
    def site_map(self):
        return self.context["site_map"]

    def known_floor(self, code: str) -> str:
        if code not in self.site_map.floors:
            raise serializers.ValidationError(f"unknown floor {code!r}")
        return code

    def known_waypoint(self, code: str) -> str:
        if code not in self.site_map.waypoints:
            raise serializers.ValidationError(f"unknown waypoint {code!r}")
        return code

    def known_resource(self, code: str) -> str:
        if code not in self.site_map.resources:
            raise serializers.ValidationError(f"unknown resource {code!r}")
        return code


class HeartbeatStateSerializer(SiteCodesMixin, serializers.Serializer):
    status = serializers.ChoiceField(choices=REPORTABLE_STATUSES)
    floor = StrictCharField(help_text="a floor code of the site")
    waypoint = StrictCharField(
        required=False, allow_null=True, help_text="waypoint the robot is at or last passed"
    )
    x = StrictFloatField(required=False, allow_null=True, help_text="metres, floor frame")
    y = StrictFloatField(required=False, allow_null=True, help_text="metres, floor frame")
    heading = StrictFloatField(required=False, allow_null=True, help_text="radians")
    battery = StrictFloatField(min_value=0.0, max_value=1.0)
    load = StrictIntegerField(min_value=0, max_value=32767, help_text="items on board")
    plan_version = StrictIntegerField(
        min_value=0, max_value=2**31 - 1, help_text="newest plan the robot has applied"
    )
    errors = serializers.ListField(
        child=StrictCharField(max_length=200, allow_blank=True),
        required=False,
        max_length=50,
        default=list,
    )

    def validate_floor(self, code):
        return self.known_floor(code)

    def validate_waypoint(self, code):
        return code if code is None else self.known_waypoint(code)

    def validate(self, attrs):
        attrs["floor_id"] = self.site_map.floor_ids[attrs["floor"]]
        waypoint = attrs.get("waypoint")
        if waypoint and self.site_map.waypoints[waypoint].floor != attrs["floor"]:
            where = self.site_map.waypoints[waypoint].floor
            raise serializers.ValidationError({"waypoint": f"{waypoint!r} is on {where}, not here"})
        attrs["waypoint_id"] = self.site_map.waypoints[waypoint].id if waypoint else None
        return attrs


class HeartbeatEventSerializer(SiteCodesMixin, serializers.Serializer):
    id = StrictCharField(max_length=64, help_text="robot-unique; applied once")
    type = serializers.ChoiceField(choices=EventType.choices)
    at = StrictDateTimeField(required=False, help_text="by the robot's clock")
    task = StrictCharField(max_length=32, required=False, help_text="task code")
    stop = StrictIntegerField(min_value=0, max_value=32767, required=False, allow_null=True)
    resource = StrictCharField(max_length=64, required=False, help_text="resource_* events")
    # Secure deliveries (an addition): who opened which compartment, and wrong PINs before.
    compartment = StrictCharField(
        max_length=16, required=False, help_text="loaded, unloaded, compartment_locked"
    )
    opened_with = serializers.ChoiceField(choices=OpenedWith.choices, required=False)
    opened_by = StrictCharField(
        max_length=64, required=False, help_text="badge id hash or staff id, if known"
    )
    failed_attempts = StrictIntegerField(
        min_value=0, max_value=1000, required=False, help_text="wrong PINs before this"
    )

    def validate_resource(self, code):
        return self.known_resource(code)

    def validate(self, attrs):
        if attrs["type"] in RESOURCE_EVENT_TYPES and not attrs.get("resource"):
            raise serializers.ValidationError({"resource": f"required for {attrs['type']}"})
        if attrs["type"] == EventType.COMPARTMENT_LOCKED and not attrs.get("compartment"):
            raise serializers.ValidationError({"compartment": "required for compartment_locked"})
        return attrs

    def to_internal_value(self, data):
        event = super().to_internal_value(data)
        event["raw"] = data
        return event


class AcquireReleaseSerializer(SiteCodesMixin, serializers.Serializer):
    id = StrictCharField(max_length=64, help_text="makes the request idempotent")
    type = serializers.ChoiceField(choices=RequestType.choices)
    resource = StrictCharField(max_length=64)
    to_floor = StrictCharField(required=False, help_text="elevators only: destination floor")

    def validate_resource(self, code):
        return self.known_resource(code)

    def validate_to_floor(self, code):
        return self.known_floor(code)

    def to_internal_value(self, data):
        request = super().to_internal_value(data)
        request["raw"] = data
        return request


class HeartbeatSerializer(FieldsKeptPerThread, serializers.Serializer):
    boot_id = StrictCharField(min_length=1, max_length=64)
    seq = StrictIntegerField(min_value=0, max_value=MAX_SEQ)
    sent_at = StrictDateTimeField(required=False, help_text="informational only")
    state = HeartbeatStateSerializer()
    events = HeartbeatEventSerializer(
        many=True, required=False, max_length=MAX_EVENTS, default=list
    )
    acks = serializers.ListField(
        child=StrictCharField(max_length=64), required=False, max_length=1000, default=list
    )
    requests = AcquireReleaseSerializer(many=True, required=False, max_length=100, default=list)
    push = StrictBooleanField(
        required=False,
        default=False,
        help_text="the robot's push channel is open (an addition): idle, it may be told a "
        "longer heartbeat_interval",
    )


# --- The plain heartbeat, validated without the serializer ------------------------------------


def heartbeat_validate(body, site_map) -> dict:
    """The heartbeat's validated data; raises ValidationError naming what is wrong."""
    plain = heartbeat_plain(body, site_map)
    if plain is not None:
        return plain
    serializer = HeartbeatSerializer(data=body, context={"site_map": site_map})
    serializer.is_valid(raise_exception=True)
    return serializer.validated_data


_STATE_NUMBERS = ("x", "y", "heading")  # optional, null allowed: floats
_STATUSES = frozenset(REPORTABLE_STATUSES)
_SENT_AT = HeartbeatSerializer._declared_fields["sent_at"]


def heartbeat_plain(body, site_map) -> dict | None:
    """HeartbeatSerializer's validated_data for the heartbeat nearly every robot sends every
    second (its state and when it was sent, maybe acks, no events or requests), or None for any
    other body, which the serializer then validates and, if it is wrong, names what is.

    The serializer's run over such a body is a large share of the instructions a heartbeat costs
    the server (bench/heartbeat_instructions.py). This takes only values the serializer would
    take unchanged (ASCII text without surrounding spaces, numbers in range, known codes), so the
    two agree
    wherever this answers (tests/boards/test_heartbeat_plain.py checks it on generated bodies).
    """
    if not isinstance(body, dict):
        return None
    if body.get("events", []) != [] or body.get("requests", []) != []:
        return None
    boot_id, seq, acks = body.get("boot_id"), body.get("seq"), body.get("acks", [])
    if not _plain_text(boot_id, 64) or not _integer(seq, MAX_SEQ):
        return None
    if type(acks) is not list or len(acks) > 1000 or not all(_plain_text(a, 64) for a in acks):
        return None
    state = _state_plain(body.get("state"), site_map)
    if state is None:
        return None
    push = body.get("push", False)
    if type(push) is not bool:
        return None
    plain = {"boot_id": boot_id, "seq": seq, "state": state, "events": [], "acks": acks}
    plain["requests"], plain["push"] = [], push
    if "sent_at" in body:
        try:  # by the serializer's own field: how it reads a date-time is its business
            plain["sent_at"] = _SENT_AT.run_validation(body["sent_at"])
        except serializers.ValidationError:
            return None
    return plain


def _state_plain(state, site_map) -> dict | None:
    if type(state) is not dict:
        return None
    status, floor, errors = state.get("status"), state.get("floor"), state.get("errors", [])
    battery, load, plan_version = state.get("battery"), state.get("load"), state.get("plan_version")
    if type(status) is not str or status not in _STATUSES:
        return None
    if not _plain_text(floor, None) or floor not in site_map.floors:
        return None
    if not _number(battery) or not 0.0 <= battery <= 1.0:
        return None
    if not _integer(load, 32767) or not _integer(plan_version, 2**31 - 1):
        return None
    if type(errors) is not list or len(errors) > 50 or not all(_plain_text(e, 200) for e in errors):
        return None
    plain = {"status": status, "floor": floor, "battery": float(battery), "load": load}
    plain |= {"plan_version": plan_version, "errors": errors}
    for name in _STATE_NUMBERS:
        if name in state:
            value = state[name]
            if value is not None and not _number(value):
                return None
            plain[name] = value if value is None else float(value)
    waypoint = None
    if "waypoint" in state:
        waypoint = plain["waypoint"] = state["waypoint"]
        if waypoint is not None and not _plain_text(waypoint, None):
            return None
        if waypoint is not None and waypoint not in site_map.waypoints:
            return None
        if waypoint and site_map.waypoints[waypoint].floor != floor:
            return None
    plain["floor_id"] = site_map.floor_ids[floor]
    plain["waypoint_id"] = site_map.waypoints[waypoint].id if waypoint else None
    return plain


def _plain_text(value, longest: int | None) -> bool:
    """A string a StrictCharField (not blank) keeps as it is."""
    return (
        type(value) is str
        and 0 < len(value) <= (longest or len(value))
        and value.isascii()
        and value.isprintable()
        and value == value.strip()
    )


def _integer(value, highest: int) -> bool:
    return type(value) is int and 0 <= value <= highest


def _number(value) -> bool:
    """A finite float, or an integer a float holds exactly."""
    if type(value) is int:
        return -(2**53) <= value <= 2**53
    return type(value) is float and math.isfinite(value)


# Response documentation. The view sends boards.protocol.message_wire(); these only describe it.


class PlanStopSerializer(serializers.Serializer):
    """A task's pick-up or drop-off; or, alone in the plan of a robot with nothing left to do,
    its dock (action "dock": no task or stop)."""

    task = serializers.CharField(required=False, help_text="not in a dock stop")
    stop = serializers.IntegerField(required=False, help_text="not in a dock stop")
    action = serializers.ChoiceField(choices=["pickup", "dropoff", "dock"])
    waypoint = serializers.CharField()
    via = serializers.ListField(child=serializers.CharField(), required=False)


class PinHashSerializer(serializers.Serializer):
    algorithm = serializers.ChoiceField(choices=["pbkdf2_sha256"])
    iterations = serializers.IntegerField(min_value=1)
    salt = serializers.CharField(help_text="hex")
    hash = serializers.CharField(help_text="hex: PBKDF2-HMAC-SHA256(PIN, salt, iterations)")


class BadgeHashSerializer(PinHashSerializer):
    holder = serializers.CharField(help_text="whose badge: report it as opened_by")
    hash = serializers.CharField(help_text="hex: PBKDF2-HMAC-SHA256(badge id, salt, iterations)")


class PlanSecureSerializer(serializers.Serializer):
    pin = PinHashSerializer()
    max_attempts = serializers.IntegerField(min_value=1, help_text="wrong PINs, then locked")
    badges = BadgeHashSerializer(
        many=True, help_text="the receiving unit's users' badges, each opens it too"
    )


class PlanTaskSerializer(serializers.Serializer):
    contents = serializers.CharField()
    sender = serializers.CharField()
    receiver = serializers.CharField()
    priority = serializers.ChoiceField(choices=["normal", "urgent"])
    secure = PlanSecureSerializer(
        required=False, help_text="a secure delivery: lock it, open for its PIN only"
    )


class PlanMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.PLAN])
    plan_version = serializers.IntegerField()
    stops = PlanStopSerializer(many=True)
    tasks = serializers.DictField(child=PlanTaskSerializer())


class ResourceGrantMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.RESOURCE_GRANT])
    request = serializers.CharField()
    resource = serializers.CharField()
    lease = serializers.CharField()
    expires_at = serializers.DateTimeField()
    to_floor = serializers.CharField(required=False)


class ResourceQueuedMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.RESOURCE_QUEUED])
    request = serializers.CharField()
    resource = serializers.CharField()
    position = serializers.IntegerField(min_value=1)


class ActionMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.ACTION])
    action = serializers.ChoiceField(choices=["pause", "resume", "return_to_dock"])


class ResourceOutOfServiceMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.RESOURCE_OUT_OF_SERVICE])
    resource = serializers.CharField()
    since = serializers.DateTimeField()
    reason = serializers.CharField(allow_blank=True)


class ResourceInServiceMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.RESOURCE_IN_SERVICE])
    resource = serializers.CharField()


class ElevatorAtFloorMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.ELEVATOR_AT_FLOOR])
    resource = serializers.CharField()
    lease = serializers.CharField()
    floor = serializers.CharField()
    doors = serializers.ChoiceField(choices=["open"])


class ElevatorExitMessageSerializer(serializers.Serializer):
    id = serializers.CharField()
    type = serializers.ChoiceField(choices=[MessageType.ELEVATOR_EXIT])
    resource = serializers.CharField()
    lease = serializers.CharField()
    floor = serializers.CharField(
        required=False, help_text="where the car stops next; left out where no lift is driven"
    )
    waypoint = serializers.CharField(required=False, help_text="the lift's lobby on `floor`")
    reason = serializers.CharField(allow_blank=True)


BoardMessageSerializer = PolymorphicProxySerializer(
    component_name="BoardMessage",
    serializers={
        MessageType.PLAN.value: PlanMessageSerializer,
        MessageType.RESOURCE_GRANT.value: ResourceGrantMessageSerializer,
        MessageType.RESOURCE_QUEUED.value: ResourceQueuedMessageSerializer,
        MessageType.ACTION.value: ActionMessageSerializer,
        MessageType.RESOURCE_OUT_OF_SERVICE.value: ResourceOutOfServiceMessageSerializer,
        MessageType.RESOURCE_IN_SERVICE.value: ResourceInServiceMessageSerializer,
        MessageType.ELEVATOR_AT_FLOOR.value: ElevatorAtFloorMessageSerializer,
        MessageType.ELEVATOR_EXIT.value: ElevatorExitMessageSerializer,
    },
    resource_type_field_name="type",
    many=True,
)


class HeartbeatResponseSerializer(serializers.Serializer):
    server_time = serializers.DateTimeField()
    heartbeat_interval = serializers.FloatField(help_text="seconds until the next heartbeat")
    map_version = serializers.IntegerField(
        min_value=1, help_text="the site map's version; a new one is published by its administrator"
    )
    messages = BoardMessageSerializer
