"""The pages' forms: the delivery request form of the deliveries page (the paper's Figure 4a),
and the operator's buttons on a robot's page.

The form only turns what the browser sends (station names, a datetime-local value, the repeat
fields, one input per pick-up or drop-off) into the API's request. The rules are the API's:
the view validates that with scheduling.serializers.TaskRequestSerializer, and the errors are
put back next to the field that caused them (add_api_errors).
"""

import re
from dataclasses import dataclass

from django import forms
from django.utils import timezone
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _

from scheduling.choices import OperatorActionKind, Priority

DATETIME_LOCAL = "%Y-%m-%dT%H:%M"
REPEAT_TIMES = "times"
REPEAT_EVERY = "every"
REPEAT_CHOICES = [
    ("", _("No")),
    (REPEAT_TIMES, _("Every day at set times")),
    (REPEAT_EVERY, _("Every few minutes within a daily window")),
]
# The form's stop inputs: (input name, the API's field, the label of the first input).
STOPS = {"pickup": ("pickups", _("Pick-up")), "dropoff": ("dropoffs", _("Drop-off"))}
# The API's fields -> this form's fields (None: the form as a whole).
API_FIELDS = {
    "site": "site",
    "requested_time": "requested_time",
    "sender": "sender",
    "receiver": "receiver",
    "contents": "contents",
    "priority": "priority",
    "secure": "secure",
    "non_field_errors": None,
}
# The API's terse words for a missing value, said per field as a person would ask for it.
MISSING = {"This field may not be blank.", "This field is required.", "This list may not be empty."}
ASK_FOR = {
    "sender": _("Say who sends it: a person or a unit."),
    "receiver": _("Say who it is for: a person or a unit."),
    "contents": _("Say what it carries, e.g. Blood sample."),
    "pickup": _("Choose the station where the robot picks it up."),
    "dropoff": _("Choose the station where the robot takes it."),
}
MATCHES_SHOWN = 5  # stations named when what was typed matches several
IN_THE_PAST = "is in the past"
PAST_TIME = _("That time has passed: choose a later one, or leave the time as shown for now.")
REPEAT_FIELDS = {
    "times": "repeat_times",
    "every_minutes": "repeat_every",
    "from": "repeat_from",
    "until": "repeat_until",
}


class DateTimeLocalInput(forms.DateTimeInput):
    input_type = "datetime-local"

    def __init__(self, attrs=None):
        super().__init__(attrs={"step": 60, **(attrs or {})}, format=DATETIME_LOCAL)


class TimeOfDayInput(forms.TextInput):
    input_type = "time"


@dataclass(frozen=True)
class StopInput:
    """One pick-up or drop-off input as the template renders it."""

    id: str
    name: str
    label: str
    value: str
    errors: list[str]
    number: int

    @property
    def error_id(self) -> str:
        return f"{self.id}_error"


class DeliveryRequestForm(forms.Form):
    # No `required` here: the API's serializer decides what is missing (and says so per field).
    use_required_attribute = False

    site = forms.ChoiceField(label=_("Site"), required=False)
    requested_time = forms.DateTimeField(
        label=_("Collection time"),
        required=False,
        widget=DateTimeLocalInput(),
        input_formats=[DATETIME_LOCAL, f"{DATETIME_LOCAL}:%S"],
        # Left as shown, it means "now" when submitted, however long the form was open.
        show_hidden_initial=True,
    )
    # The API's limits, so the browser stops the typing where the server would refuse it.
    sender = forms.CharField(label=_("Sender"), required=False, strip=True, max_length=200)
    receiver = forms.CharField(label=_("Receiver"), required=False, strip=True, max_length=200)
    contents = forms.CharField(label=_("Contents"), required=False, strip=True, max_length=200)
    priority = forms.ChoiceField(label=_("Priority"), choices=Priority.choices, required=False)
    repeat = forms.ChoiceField(label=_("Repeat"), choices=REPEAT_CHOICES, required=False)
    secure = forms.BooleanField(
        label=_("Secure (PIN)"),
        required=False,
        help_text=_("Locked; opens with a PIN you see once."),
    )
    repeat_times = forms.CharField(
        label=_("Daily times"),
        required=False,
        help_text=_("HH:MM, separated by commas: 08:00, 14:00"),
    )
    repeat_every = forms.IntegerField(label=_("Every (minutes)"), required=False)
    repeat_from = forms.CharField(label=_("Window from"), required=False, widget=TimeOfDayInput)
    repeat_until = forms.CharField(label=_("Window until"), required=False, widget=TimeOfDayInput)

    def __init__(self, data=None, *, sites, site, stations: list[tuple[str, str]], **kwargs):
        now = timezone.localtime().replace(second=0, microsecond=0)
        initial = {"site": site.code, "requested_time": now, "priority": Priority.ROUTINE}
        super().__init__(data, initial=initial, **kwargs)
        self.fields["site"].choices = [(s.code, str(s)) for s in sites]
        if len(sites) < 2:
            self.fields["site"].widget = forms.HiddenInput()
        self.station_codes = _station_codes(stations)
        self.stations = stations
        self.ambiguous: dict[str, list[str]] = {}  # typed (casefolded) -> the names it matches
        self.stop_values = {name: self._submitted(name) for name in STOPS}
        self.stop_errors: dict[str, dict[int | None, list[str]]] = {name: {} for name in STOPS}
        for name in ("sender", "receiver", "contents"):
            self.fields[name].widget.attrs["autocomplete"] = "off"

    def _submitted(self, name: str) -> list[str]:
        values = [value.strip() for value in self.data.getlist(name)] if self.is_bound else []
        return values or [""]

    # --- What the template shows -------------------------------------------------------------

    @property
    def pickup_inputs(self) -> list[StopInput]:
        return self._inputs("pickup")

    @property
    def dropoff_inputs(self) -> list[StopInput]:
        return self._inputs("dropoff")

    @property
    def pickup_group_errors(self) -> list[str]:
        return self.stop_errors["pickup"].get(None, [])

    @property
    def dropoff_group_errors(self) -> list[str]:
        return self.stop_errors["dropoff"].get(None, [])

    def _inputs(self, name: str) -> list[StopInput]:
        label = STOPS[name][1]
        return [
            StopInput(
                id=f"id_{name}" if n == 1 else f"id_{name}_{n}",
                name=name,
                label=label if n == 1 else f"{label} {n}",
                value=value,
                errors=self.stop_errors[name].get(n - 1, []),
                number=n,
            )
            for n, value in enumerate(self.stop_values[name], start=1)
        ]

    # --- To and from the API -----------------------------------------------------------------

    def api_data(self) -> dict:
        """The request as the API takes it (call after is_valid()): what the form could read,
        even if not all of it, so the API can say what else is wrong."""
        cleaned = self.cleaned_data
        data = {
            "sender": cleaned.get("sender", ""),
            "receiver": cleaned.get("receiver", ""),
            "contents": cleaned.get("contents", ""),
            "priority": cleaned.get("priority") or Priority.ROUTINE,
            "secure": bool(cleaned.get("secure")),
        }
        for name, (api_name, _label) in STOPS.items():
            data[api_name] = [self._station_code(value) for value in self.stop_values[name]]
        if cleaned.get("site"):
            data["site"] = cleaned["site"]
        when = cleaned.get("requested_time")
        if when is not None and "requested_time" in self.changed_data:
            data["requested_time"] = when.isoformat()
        repeat = self._repeat()
        if repeat is not None:
            data["repeat"] = repeat
        return data

    def _repeat(self) -> dict | None:
        mode, data = self.cleaned_data.get("repeat"), self.cleaned_data
        if mode == REPEAT_TIMES:
            return {"times": [t for t in re.split(r"[,\s]+", data.get("repeat_times", "")) if t]}
        if mode == REPEAT_EVERY:
            window = {"from": data.get("repeat_from"), "until": data.get("repeat_until")}
            repeat = {key: value for key, value in window.items() if value}
            if data.get("repeat_every") is not None:
                repeat["every_minutes"] = data["repeat_every"]
            elif "repeat_every" in self.errors:  # unreadable: the form says so, not the API
                repeat["every_minutes"] = 1
            return repeat
        return None

    def add_api_errors(self, errors: dict) -> None:
        """Put the API's validation errors next to the form's fields they are about (all of
        them at once, stations named by name)."""
        self.repeat_mode = self.cleaned_data.get("repeat")
        for key, problems in errors.items():
            stop = next((name for name, (api, _label) in STOPS.items() if api == key), None)
            if stop is not None:
                self._stop_errors(stop, problems)
            elif key == "repeat":
                self._repeat_errors(problems)
            else:
                self._error(API_FIELDS.get(key), problems)

    def _station_code(self, typed: str) -> str:
        """The code of the station `typed` names: its name or code, else the one station whose
        name or code holds it ("Ward 6A", "lab"); what was typed if none or several do."""
        found = self.station_codes.get(typed.casefold())
        if found is not None or not typed:
            return found or typed
        part = typed.casefold()
        matches = [
            (code, name) for code, name in self.stations if part in f"{name} {code}".casefold()
        ]
        if len(matches) == 1:
            return matches[0][0]
        if matches:
            self.ambiguous[part] = [name for _code, name in matches]
        return typed

    def _stop_errors(self, name: str, problems) -> None:
        if isinstance(problems, dict):  # by index of the stop
            for index, messages in problems.items():
                texts = self._which_station(name, int(index), _in_words(name, _texts(messages)))
                self.stop_errors[name].setdefault(int(index), []).extend(texts)
        else:
            self.stop_errors[name].setdefault(None, []).extend(_in_words(name, _texts(problems)))

    def _which_station(self, name: str, index: int, texts: list[str]) -> list[str]:
        """For a stop whose typed words match several stations, which ones."""
        values = self.stop_values[name]
        typed = values[index] if index < len(values) else ""
        names = self.ambiguous.get(typed.casefold())
        if not names:
            return texts
        shown = ", ".join(names[:MATCHES_SHOWN]) + (", …" if len(names) > MATCHES_SHOWN else "")
        said = gettext("“%(typed)s” matches %(count)d stations (%(shown)s): type more of the name.")
        return [said % {"typed": typed, "count": len(names), "shown": shown}]

    def _repeat_errors(self, problems) -> None:
        if not isinstance(problems, dict):
            self._error("repeat", problems)
            return
        whole = "repeat_every" if self.repeat_mode == REPEAT_EVERY else "repeat_times"
        for key, messages in problems.items():
            field = REPEAT_FIELDS.get(key, whole)
            if key == "times" and isinstance(messages, dict):  # by index of the time
                messages = [text for each in messages.values() for text in _texts(each)]
            self._error(field, messages)

    def _error(self, field: str | None, problems) -> None:
        if field is not None and field in self.errors:
            return  # the form could not read it, and says so already
        self.add_error(field, _in_words(field, _texts(problems)))

    @property
    def has_stop_errors(self) -> bool:
        return any(self.stop_errors.values())


def _station_codes(stations: list[tuple[str, str]]) -> dict[str, str]:
    """Casefolded station names and codes -> code; a name two stations share is left out."""
    names: dict[str, list[str]] = {}
    for code, name in stations:
        names.setdefault(name.casefold(), []).append(code)
    codes = {name: found[0] for name, found in names.items() if len(found) == 1}
    codes.update({code.casefold(): code for code, _name in stations})
    return codes


def _in_words(field: str | None, texts: list[str]) -> list[str]:
    """The API's words, with a missing value asked for and a past time explained."""
    said = []
    # DRF says these in the page's language (its own catalogs).
    missing = {gettext(each) for each in MISSING}
    for text in texts:
        if text in missing and field in ASK_FOR:
            text = ASK_FOR[field]
        elif text == IN_THE_PAST and field == "requested_time":
            text = PAST_TIME
        said.append(text)
    return said


def _texts(problems) -> list[str]:
    if isinstance(problems, dict):
        return [text for each in problems.values() for text in _texts(each)]
    if isinstance(problems, list | tuple):
        return [str(problem) for problem in problems]
    return [str(problems)]


class RobotActionForm(forms.Form):
    """An operator's button on the robot page: Pause, Resume or Return to dock."""

    action = forms.ChoiceField(choices=OperatorActionKind.choices)


class ResourceServiceForm(forms.Form):
    """An operator takes a resource out of service (with a reason) or returns it."""

    in_service = forms.TypedChoiceField(
        choices=[("true", "in service"), ("false", "out of service")],
        coerce=lambda value: value == "true",
    )
    reason = forms.CharField(max_length=200, required=False, strip=True)

    def clean(self):
        cleaned = super().clean()
        if cleaned.get("in_service") is False and not cleaned.get("reason"):
            self.add_error("reason", _("say why it is out of service"))
        return cleaned


class LiftPriorityForm(forms.Form):
    """An operator holds an elevator for an emergency team (with a reason) or releases it."""

    on = forms.TypedChoiceField(
        choices=[("true", "hold"), ("false", "release")], coerce=lambda value: value == "true"
    )
    reason = forms.CharField(max_length=200, required=False, strip=True)

    def clean(self):
        cleaned = super().clean()
        if cleaned.get("on") is True and not cleaned.get("reason"):
            self.add_error("reason", "say who needs the lift")
        return cleaned


class DoorHoldForm(forms.Form):
    hold = forms.TypedChoiceField(
        choices=[("true", "hold"), ("false", "let go")], coerce=lambda value: value == "true"
    )


class CarSendForm(forms.Form):
    floor = forms.CharField(max_length=32)


def _secret_input(**attrs) -> forms.PasswordInput:
    """Typed or scanned, never shown again (the page never carries it back)."""
    return forms.PasswordInput(render_value=False, attrs={"autocomplete": "off", **attrs})


class IdentifyForm(forms.Form):
    """Who is ordering at a shared workstation: their badge and PIN, or their user name and
    password. Both fields of one way must be given."""

    use_required_attribute = False

    badge = forms.CharField(
        label=_("Badge"), required=False, max_length=128, strip=True, widget=_secret_input()
    )
    pin = forms.CharField(
        label=_("PIN"),
        required=False,
        max_length=8,
        strip=True,
        widget=_secret_input(inputmode="numeric"),
    )
    username = forms.CharField(label=_("User name"), required=False, max_length=150, strip=True)
    password = forms.CharField(
        label=_("Password"), required=False, strip=False, widget=_secret_input()
    )

    def clean(self):
        cleaned = super().clean()
        badge, pin = cleaned.get("badge"), cleaned.get("pin")
        username, password = cleaned.get("username"), cleaned.get("password")
        if badge or pin:
            if not badge:
                self.add_error("badge", _("Scan your badge as well as typing your PIN."))
            if not pin:
                self.add_error("pin", _("Type your PIN after scanning your badge."))
        elif username or password:
            if not username:
                self.add_error("username", _("Type your user name as well as your password."))
            if not password:
                self.add_error("password", _("Type your password as well as your user name."))
        else:
            self.add_error("badge", _("Scan your badge and type your PIN to confirm the order."))
        return cleaned


class PinForm(forms.Form):
    """A person sets their own workstation PIN (typed twice)."""

    use_required_attribute = False

    pin = forms.CharField(
        label=_("New PIN"), max_length=8, strip=True, widget=_secret_input(inputmode="numeric")
    )
    pin_again = forms.CharField(
        label=_("New PIN again"),
        max_length=8,
        strip=True,
        widget=_secret_input(inputmode="numeric"),
    )

    def clean(self):
        cleaned = super().clean()
        if (
            cleaned.get("pin")
            and cleaned.get("pin_again")
            and cleaned["pin"] != cleaned["pin_again"]
        ):
            self.add_error("pin_again", _("The two PINs differ: type the same PIN twice."))
        return cleaned


class FireAlarmForm(forms.Form):
    """An operator starts a fire alarm (on the floors ticked; none: every floor) or ends it."""

    start = forms.TypedChoiceField(
        choices=[("true", _("start")), ("false", _("all clear"))],
        coerce=lambda value: value == "true",
    )
    floors = forms.MultipleChoiceField(required=False, choices=())
    reason = forms.CharField(max_length=200, required=False, strip=True)

    def __init__(self, *args, floors=(), **kwargs):
        super().__init__(*args, **kwargs)
        self.fields["floors"].choices = list(floors)


class RobotMaintenanceForm(forms.Form):
    """An operator takes a robot out of service for maintenance (with a reason, optionally
    until a time) or returns it."""

    in_service = forms.TypedChoiceField(
        choices=[("true", _("in service")), ("false", _("in maintenance"))],
        coerce=lambda value: value == "true",
    )
    reason = forms.CharField(max_length=200, required=False, strip=True)
    until = forms.DateTimeField(required=False, input_formats=["%Y-%m-%dT%H:%M"])

    def clean(self):
        cleaned = super().clean()
        if cleaned.get("in_service") is False and not cleaned.get("reason"):
            self.add_error("reason", _("Say why it goes into maintenance."))
        return cleaned
