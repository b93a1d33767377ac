"""Delivery tasks on the API: request validation and what is shown."""

from collections.abc import Mapping
from datetime import timedelta

from django.core.exceptions import ValidationError as DjangoValidationError
from django.utils import timezone
from rest_framework import serializers
from rest_framework.fields import SkipField, get_error_detail

from core.fields import StrictCharField, StrictDateTimeField, StrictIntegerField
from core.serializers import FieldsKeptPerThread
from robots.models import Site
from scheduling.choices import PRIORITY_ALIASES, Priority, TaskStatus
from scheduling.deadlines import lateness_note, priority_of
from scheduling.models import RecurringRequest, Task, TaskStop, TaskTransition
from scheduling.recurrence import MINUTES_PER_DAY, parse_clock
from scheduling.selectors import stations_by_code

# A requested time this far in the past is taken as "now" (clocks of hospital systems differ).
PAST_TOLERANCE = timedelta(minutes=1)
MAX_STOPS = 10


class RepeatSerializer(serializers.Serializer):
    """{"times": ["08:00", "14:00"]} or {"every_minutes": 120, "from": "08:00", "until": "20:00"}"""

    def get_fields(self):
        clock = {"required": False, "help_text": "HH:MM, site local time"}
        return {
            "times": serializers.ListField(
                child=StrictCharField(),
                required=False,
                min_length=1,
                max_length=48,
                help_text="every day at these local times (HH:MM)",
            ),
            "every_minutes": StrictIntegerField(
                required=False, min_value=1, max_value=MINUTES_PER_DAY
            ),
            "from": StrictCharField(**clock),
            "until": StrictCharField(**clock),
        }

    def validate_times(self, times):
        errors = {n: [f"{text!r} is not HH:MM"] for n, text in enumerate(times) if not _clock(text)}
        if errors:
            raise serializers.ValidationError(errors)
        if len(set(times)) != len(times):
            raise serializers.ValidationError("a time is repeated")
        return times

    def validate(self, attrs):
        if ("times" in attrs) == ("every_minutes" in attrs):
            raise serializers.ValidationError("give either times or every_minutes")
        if "times" in attrs:
            return {"times": attrs["times"]}
        return {"every_minutes": attrs["every_minutes"], **_window(attrs)}


def _clock(text: str):
    try:
        return parse_clock(text)
    except ValueError:
        return None


def _window(attrs: dict) -> dict:
    errors = {}
    for name in ("from", "until"):
        if name not in attrs:
            errors[name] = ["required with every_minutes"]
        elif _clock(attrs[name]) is None:
            errors[name] = [f"{attrs[name]!r} is not HH:MM"]
    if not errors and _clock(attrs["from"]) >= _clock(attrs["until"]):
        errors["until"] = ["must be after from"]
    if errors:
        raise serializers.ValidationError(errors)
    return {"from": attrs["from"], "until": attrs["until"]}


class TaskRequestSerializer(FieldsKeptPerThread, serializers.Serializer):
    site = StrictCharField(required=False, help_text="site code; needed only with several sites")
    sender = StrictCharField(max_length=200)
    receiver = StrictCharField(max_length=200)
    contents = StrictCharField(max_length=200)
    priority = serializers.ChoiceField(
        choices=[*Priority.values, *PRIORITY_ALIASES],
        default=Priority.ROUTINE,
        help_text="routine, urgent or stat (`normal`, the old name of routine, is accepted)",
    )
    requested_time = StrictDateTimeField(
        required=False, help_text="when a robot should come; default now"
    )
    due_by = StrictDateTimeField(
        required=False,
        help_text="when it must be dropped off; default the site's for its priority",
    )
    pickups = serializers.ListField(
        child=StrictCharField(), min_length=1, max_length=MAX_STOPS, help_text="station codes"
    )
    dropoffs = serializers.ListField(
        child=StrictCharField(), min_length=1, max_length=MAX_STOPS, help_text="station codes"
    )
    repeat = RepeatSerializer(required=False, help_text="makes it a periodic request")
    secure = serializers.BooleanField(
        default=False,
        help_text="locked in a compartment that opens for the recipient's PIN (answered once, "
        "as `pin`) and goes only to a robot with a lockable compartment; not with `repeat`",
    )

    def validate_site(self, code):
        site = Site.objects.filter(code=code).first()
        if site is None:
            raise serializers.ValidationError(f"unknown site {code!r}")
        return site

    def validate_requested_time(self, moment):
        if moment < timezone.now() - PAST_TOLERANCE:
            raise serializers.ValidationError("is in the past")
        return moment

    def validate_priority(self, name):
        return priority_of(name)

    def to_internal_value(self, data):
        """Every problem at once: each field's own, and those between fields that the valid
        ones show (stations unknown on the site, repeated, both pick-up and drop-off...), so
        one answer (and the delivery form) lists all of them; stations are named by name."""
        if not isinstance(data, Mapping):
            return super().to_internal_value(data)  # refused in DRF's words
        attrs, errors = _fields_parsed(self, data)
        errors = {**_between(attrs, errors), **errors}
        if errors:
            raise serializers.ValidationError(errors)
        stations = attrs.pop("stations")
        attrs["pickups"] = [stations[code] for code in attrs["pickups"]]
        attrs["dropoffs"] = [stations[code] for code in attrs["dropoffs"]]
        return attrs


def _fields_parsed(serializer: serializers.Serializer, data) -> tuple[dict, dict]:
    """(the valid fields' values, the others' errors): DRF's own loop over the fields, which
    keeps the valid values where DRF drops them on the first error."""
    attrs, errors = {}, {}
    for field in serializer._writable_fields:
        check = getattr(serializer, f"validate_{field.field_name}", None)
        try:
            value = field.run_validation(field.get_value(data))
            attrs[field.source] = check(value) if check else value
        except serializers.ValidationError as exc:
            errors[field.field_name] = exc.detail
        except DjangoValidationError as exc:
            errors[field.field_name] = get_error_detail(exc)
        except SkipField:
            continue
    return attrs, errors


def _between(attrs: dict, errors: dict) -> dict:
    """The problems between fields, each checked once the fields it needs are valid; sets
    attrs["site"] and attrs["stations"] (code -> Waypoint) on the way."""
    found: dict = {}
    if "site" not in errors:
        attrs["site"] = attrs.get("site") or _only_site(found)
    if "due_by" in attrs and "requested_time" not in errors:
        _due_by_check(attrs, found)
    if attrs.get("secure") and attrs.get("repeat"):
        found["secure"] = ["a secure delivery cannot repeat: each has a PIN of its own"]
    if attrs.get("site") is None:
        return found
    pickups, dropoffs = attrs.get("pickups", []), attrs.get("dropoffs", [])
    stations = stations_by_code(site=attrs["site"], codes=pickups + dropoffs)
    attrs["stations"] = stations
    found.update(_station_errors("pickups", pickups, stations, ()))
    found.update(_station_errors("dropoffs", dropoffs, stations, pickups))
    several = len(pickups) > 1 and len(dropoffs) > 1
    if several and not {"pickups", "dropoffs"} & {*found, *errors}:
        found["dropoffs"] = ["several pick-ups need exactly one drop-off (no many-to-many)"]
    return found


def _due_by_check(attrs: dict, found: dict) -> None:
    if "repeat" in attrs:
        why = "not with repeat: each occurrence is due by the site's default for its priority"
        found["due_by"] = [why]
    elif attrs["due_by"] <= attrs.get("requested_time", timezone.now()):
        found["due_by"] = ["must be after the requested time"]


def _only_site(found: dict) -> Site | None:
    sites = list(Site.objects.all()[:2])  # one site, or "name the site"
    if len(sites) != 1:
        found["site"] = ["required: name the site"]
        return None
    return sites[0]


def _station_errors(name: str, codes: list[str], stations: dict, pickups) -> dict:
    """Problems with the stations of `codes`, named by their names ("Pharmacy is given
    twice"); an unknown one as it was given."""
    errors = {}
    for n, code in enumerate(codes):
        if code not in stations:
            errors[n] = [f"unknown station {code!r}"]
        elif code in codes[:n]:
            errors[n] = [f"{stations[code].label} is given twice"]
        elif code in pickups:
            errors[n] = [f"{stations[code].label} is also a pick-up"]
    return {name: errors} if errors else {}


class TaskStopSerializer(serializers.ModelSerializer):
    stop = serializers.IntegerField(source="index")
    waypoint = serializers.CharField(source="waypoint.code")
    station = serializers.CharField(source="waypoint.label")

    class Meta:
        model = TaskStop
        fields = ["stop", "action", "waypoint", "station", "done_at", "skipped_at"]


class RecurringSerializer(serializers.ModelSerializer):
    class Meta:
        model = RecurringRequest
        fields = ["id", "repeat", "active"]


STATUS_HELP = f"one of: {', '.join(TaskStatus.values)}"


class TaskSerializer(FieldsKeptPerThread, serializers.ModelSerializer):
    code = serializers.CharField(read_only=True)
    # Plain strings in the schema: enums named "status"/"priority" exist in the robot protocol.
    status = serializers.CharField(help_text=STATUS_HELP)
    priority = serializers.CharField(help_text=f"one of: {', '.join(Priority.values)}")
    site = serializers.CharField(source="site.code")
    requester = serializers.CharField(source="requester.username", allow_null=True)
    robot = serializers.CharField(source="robot.code", allow_null=True)
    stops = TaskStopSerializer(many=True)
    recurring = RecurringSerializer(allow_null=True)
    lateness = serializers.SerializerMethodField(
        help_text='"earliest drop-off 14:32, 7 min after it is due" when the ETA is after '
        "due_at; empty when on time or not yet estimated"
    )

    class Meta:
        model = Task
        fields = [
            "code",
            "status",
            "site",
            "priority",
            "sender",
            "receiver",
            "contents",
            "requested_time",
            "requester",
            "robot",
            "return_trip",
            "secure",
            "due_at",
            "pickup_eta",
            "eta",
            "lateness",
            "waiting_reason",
            "stops",
            "recurring",
            "scheduled_for",
            "created_at",
            "assigned_at",
            "acknowledged_at",
            "picked_up_at",
            "delivered_at",
            "completed_at",
            "cancelled_at",
            "failed_at",
        ]
        read_only_fields = fields

    def get_lateness(self, task: Task) -> str:
        if task.delivered_at is not None:
            return ""
        return lateness_note(eta=task.eta, due_at=task.due_at)


class TaskTransitionSerializer(serializers.ModelSerializer):
    old = serializers.CharField(help_text="status before; empty when the task was created")
    new = serializers.CharField(help_text=STATUS_HELP)
    robot = serializers.CharField(source="robot.code", allow_null=True)
    event = serializers.CharField(source="event.event_id", allow_null=True)
    event_type = serializers.CharField(source="event.type", allow_null=True)
    user = serializers.CharField(source="user.username", allow_null=True)

    class Meta:
        model = TaskTransition
        fields = ["at", "old", "new", "cause", "robot", "event", "event_type", "user", "note"]
        read_only_fields = fields


class TaskDetailSerializer(TaskSerializer):
    history = TaskTransitionSerializer(many=True)

    class Meta(TaskSerializer.Meta):
        fields = [*TaskSerializer.Meta.fields, "history"]
        read_only_fields = fields


class ResourceServiceSerializer(serializers.Serializer):
    """An elevator, door or corridor and whether it is in service."""

    site = serializers.CharField(source="site.code")
    code = serializers.CharField()
    kind = serializers.CharField()
    in_service = serializers.BooleanField()
    out_of_service_since = serializers.DateTimeField(allow_null=True)
    out_of_service_reason = serializers.CharField()
    priority_since = serializers.DateTimeField(
        allow_null=True, help_text="an elevator held for an emergency team since then"
    )
    priority_reason = serializers.CharField()


class ResourceOutOfServiceSerializer(serializers.Serializer):
    reason = StrictCharField(max_length=200, help_text="why, for the operators and the robots")


class LiftPrioritySerializer(serializers.Serializer):
    reason = StrictCharField(max_length=200, help_text="who needs the lift, for the operators")


class FireAlarmStartSerializer(serializers.Serializer):
    floors = serializers.ListField(
        child=StrictCharField(max_length=32),
        max_length=200,
        required=False,
        default=list,
        help_text="floor codes of the site it covers; empty or left out: every floor",
    )
    reason = StrictCharField(
        max_length=200, required=False, default="", allow_blank=True, help_text="what raised it"
    )


class FireAlarmSerializer(serializers.Serializer):
    """The site's fire alarm: `active` false when none is in force (the other fields null)."""

    site = serializers.CharField()
    active = serializers.BooleanField()
    floors = serializers.ListField(child=serializers.CharField(), allow_null=True)
    reason = serializers.CharField(allow_null=True)
    started_at = serializers.DateTimeField(allow_null=True)
    started_by = serializers.CharField(allow_null=True)
    started_via = serializers.CharField(allow_null=True)
    stopped_robots = serializers.ListField(child=serializers.CharField(), allow_null=True)
    refuges = serializers.DictField(
        child=serializers.CharField(),
        allow_null=True,
        help_text="robot code -> the refuge point it was sent to",
    )

    @staticmethod
    def of(site: Site, emergency) -> dict:
        if emergency is None:
            keys = ("floors", "reason", "started_at", "started_by", "started_via", "refuges")
            return {"site": site.code, "active": False, "stopped_robots": None} | dict.fromkeys(
                keys
            )
        by = emergency.started_by
        return {
            "site": site.code,
            "active": emergency.ended_at is None,
            "floors": emergency.floors,
            "reason": emergency.reason,
            "started_at": emergency.started_at,
            "started_by": by.get_username() if by is not None else None,
            "started_via": emergency.started_via,
            "stopped_robots": emergency.stopped_robots,
            "refuges": emergency.refuges,
        }


class RobotMaintenanceSerializer(serializers.Serializer):
    reason = StrictCharField(max_length=200, help_text="why, for the other operators")
    until = StrictDateTimeField(
        required=False, allow_null=True, default=None, help_text="returned to service then"
    )
