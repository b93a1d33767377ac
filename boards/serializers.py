"""The heartbeat on the wire (protocol v1): request validation and response documentation."""

from drf_spectacular.utils import PolymorphicProxySerializer
from rest_framework import serializers

from boards.choices import RESOURCE_EVENT_TYPES, EventType, MessageType, OpenedWith, RequestType
from core.fields import (
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
