"""An ordered Task read as a delivery request (docs/integrators/fhir.md, "Mapping"): every
problem found at once, each named by its FHIRPath, before anything is written.

    priority routine | urgent | asap | stat     -> routine | urgent | stat | stat
    restriction.period.start / .end            -> requested time / the deadline (due by)
    input pickup / dropoff (valueReference)    -> the stops: stations, as Locations
    input secure (valueBoolean) + recipient    -> a secure delivery, its PIN in the answer
    description (else code.text)               -> what is carried
    identifier, focus, for, requester, intent  -> kept (fhir_r4.models.Order)
"""

from dataclasses import dataclass, field
from datetime import date, datetime, timedelta

from django.db.models import Q
from django.utils import timezone

from fhir_r4 import codes
from fhir_r4.outcomes import FhirError, Issue
from robots.choices import WaypointKind
from robots.membership import member_site_ids
from robots.models import Site, Waypoint
from scheduling.choices import Priority
from scheduling.selectors import stations_by_code

# FHIR's request priorities onto ours: "asap" is above urgent, and stat is our only level there.
PRIORITIES = {
    "routine": Priority.ROUTINE,
    "urgent": Priority.URGENT,
    "asap": Priority.STAT,
    "stat": Priority.STAT,
}
INTENTS = ("order", "original-order", "filler-order")
MAX_STOPS = 10
TEXT_MAX = 200  # sender, receiver and contents are stored in fields this long
REFERENCE_TEXT_MAX = 500
# A requested time this far in the past is taken as "now" (clocks of hospital systems differ).
PAST_TOLERANCE = timedelta(minutes=1)
STATION_PREFIX = "station-"
SITE_PREFIX = "site-"


@dataclass
class OrderRequest:
    """What scheduling.services.task_request needs, and what fhir_r4.models.Order keeps."""

    site: Site
    pickups: list[Waypoint]
    dropoffs: list[Waypoint]
    priority: str
    fhir_priority: str
    intent: str
    contents: str
    sender: str
    receiver: str
    requested_time: datetime | None
    due_by: datetime | None
    secure: bool
    identifier: tuple[str, str] | None
    focus: dict | None
    beneficiary: dict | None
    requester: dict | None


@dataclass
class _Found:
    """What an ordered Task says, and the problems found so far."""

    issues: list[Issue] = field(default_factory=list)
    stops: dict[str, list[tuple[str, object]]] = field(
        default_factory=lambda: {codes.PICKUP: [], codes.DROPOFF: []}
    )
    secure: bool = False
    recipient: str = ""

    def problem(self, code: str, words: str, path: str) -> None:
        self.issues.append(Issue(code, words, (path,)))


def order_request(resource, *, user, now: datetime | None = None) -> OrderRequest:
    """The delivery the validated Task `resource` orders; FhirError 422 naming each problem."""
    now = now or timezone.now()
    found = _Found()
    _status_check(resource, found)
    fhir_priority = resource.priority or "routine"
    if fhir_priority not in PRIORITIES:
        found.problem("value", "use routine, urgent, asap or stat", "Task.priority")
    intent = resource.intent
    if intent not in INTENTS:
        found.problem("value", f"use {', '.join(INTENTS)}", "Task.intent")
    _inputs(resource, found)
    contents = _contents(resource, found)
    requested_time, due_by = _period(resource, found, now)
    identifier = _identifier(resource, found)
    kept = {
        "focus": _reference_kept(resource.focus, "Task.focus", found),
        "beneficiary": _reference_kept(resource.for_fhir, "Task.for", found),
        "requester": _reference_kept(resource.requester, "Task.requester", found, display=True),
    }
    site, pickups, dropoffs = _stations(resource, found, user)
    if found.issues:
        raise FhirError(422, found.issues)
    return OrderRequest(
        site=site,
        pickups=pickups,
        dropoffs=dropoffs,
        priority=PRIORITIES[fhir_priority],
        fhir_priority=fhir_priority,
        intent=intent,
        contents=contents,
        sender=pickups[0].label[:TEXT_MAX],
        receiver=(found.recipient or dropoffs[0].label)[:TEXT_MAX],
        requested_time=requested_time,
        due_by=due_by,
        secure=found.secure,
        identifier=identifier,
        **kept,
    )


def _status_check(resource, found: _Found) -> None:
    if resource.status != "requested":
        found.problem("value", "a new delivery is ordered with status requested", "Task.status")


def _inputs(resource, found: _Found) -> None:
    for n, item in enumerate(resource.input or []):
        path = f"Task.input[{n}]"
        kind = _input_type(item.type)
        if kind is None:
            words = f"type: one of {', '.join(codes.INPUT_TYPES)} (system {codes.INPUT_SYSTEM})"
            found.problem("value", words, f"{path}.type")
        elif kind in (codes.PICKUP, codes.DROPOFF):
            if item.valueReference is None:
                found.problem("required", "a Location (station) as valueReference", f"{path}")
            else:
                found.stops[kind].append((f"{path}.valueReference", item.valueReference))
        elif kind == codes.SECURE:
            if item.valueBoolean is None:
                found.problem("required", "valueBoolean", path)
            found.secure = bool(item.valueBoolean)
        else:
            _recipient(item, path, found)
    if found.secure and not found.recipient:
        words = "a secure delivery names its recipient (input recipient)"
        found.problem("required", words, "Task.input")


def _input_type(concept) -> str | None:
    for coding in concept.coding or []:
        if coding.system in (None, codes.INPUT_SYSTEM) and coding.code in codes.INPUT_TYPES:
            return coding.code
    return None


def _recipient(item, path: str, found: _Found) -> None:
    name = item.valueString
    if name is None and item.valueReference is not None:
        name = item.valueReference.display
    if not name:
        found.problem("required", "valueString, or valueReference with a display", path)
    elif len(name) > TEXT_MAX:
        found.problem("too-long", f"at most {TEXT_MAX} characters", path)
    else:
        found.recipient = name


def _contents(resource, found: _Found) -> str:
    """What is carried: Task.description, else Task.code.text."""
    text = resource.description or (resource.code.text if resource.code else None)
    if not text:
        found.problem("required", "say what is carried (Task.description)", "Task.description")
        return ""
    if len(text) > TEXT_MAX:
        found.problem("too-long", f"at most {TEXT_MAX} characters", "Task.description")
    return text


def _period(resource, found: _Found, now: datetime):
    period = resource.restriction.period if resource.restriction else None
    if period is None:
        return None, None
    start = _moment(period.start, "Task.restriction.period.start", found)
    end = _moment(period.end, "Task.restriction.period.end", found)
    if start is not None and start < now - PAST_TOLERANCE:
        found.problem("value", "is in the past", "Task.restriction.period.start")
    if end is not None and end <= max(start or now, now):
        found.problem("value", "the deadline has passed already", "Task.restriction.period.end")
    return start, end


def _moment(value, path: str, found: _Found) -> datetime | None:
    """A dateTime with a time and zone; a date alone says no time of day."""
    if value is None:
        return None
    if isinstance(value, date) and not isinstance(value, datetime):
        found.problem("value", "a date and time with its zone, not a date alone", path)
        return None
    return value


def _identifier(resource, found: _Found) -> tuple[str, str] | None:
    identifiers = resource.identifier or []
    if len(identifiers) > 1:
        found.problem("value", "one business identifier per delivery", "Task.identifier[1]")
    if not identifiers:
        return None
    system, value = identifiers[0].system or "", identifiers[0].value or ""
    if not value:
        found.problem("required", "value", "Task.identifier[0].value")
    elif len(value) > TEXT_MAX:
        found.problem("too-long", f"at most {TEXT_MAX} characters", "Task.identifier[0].value")
    if len(system) > REFERENCE_TEXT_MAX:
        words = f"at most {REFERENCE_TEXT_MAX} characters"
        found.problem("too-long", words, "Task.identifier[0].system")
    return system, value


def _reference_kept(reference, path: str, found: _Found, *, display: bool = False):
    """The reference as kept: `reference`, `type` and `identifier` (system, value), and the
    display only where it names no patient (the requester)."""
    if reference is None:
        return None
    kept = {"reference": reference.reference, "type": reference.type}
    if reference.identifier is not None:
        kept["identifier"] = {
            "system": reference.identifier.system,
            "value": reference.identifier.value,
        }
    if display:
        kept["display"] = reference.display
    kept = _without_none(kept)
    if not kept:
        found.problem("required", "a reference, an identifier or a display", path)
    if any(len(text) > REFERENCE_TEXT_MAX for text in _texts(kept)):
        found.problem("too-long", f"at most {REFERENCE_TEXT_MAX} characters each", path)
    return kept or None


def _without_none(value):
    if isinstance(value, dict):
        pruned = {key: _without_none(item) for key, item in value.items() if item is not None}
        return {key: item for key, item in pruned.items() if item not in ({}, None)}
    return value


def _texts(value):
    if isinstance(value, dict):
        for item in value.values():
            yield from _texts(item)
    elif isinstance(value, str):
        yield value


# --- Stations ---------------------------------------------------------------------------------


def _stations(resource, found: _Found, user):
    """The Task's site and its pick-ups and drop-offs, each a station of that site."""
    pickups, dropoffs = found.stops[codes.PICKUP], found.stops[codes.DROPOFF]
    if not pickups or not dropoffs:
        words = "at least one pickup and one dropoff input, each a Location"
        found.problem("required", words, "Task.input")
        return None, [], []
    if len(pickups) > MAX_STOPS or len(dropoffs) > MAX_STOPS:
        words = f"at most {MAX_STOPS} pickups and {MAX_STOPS} dropoffs"
        found.problem("value", words, "Task.input")
        return None, [], []
    sites = member_site_ids(user)
    wanted = [(path, _station_key(ref, path, found)) for path, ref in (*pickups, *dropoffs)]
    candidates = _candidates([key for _, key in wanted if key], sites)
    site = _site(resource, wanted, candidates, sites, found)
    if site is None:
        return None, [], []
    chosen = [(path, _on_site(key, candidates, site)) for path, key in wanted]
    current = stations_by_code(site=site, codes=[wp.code for _, wp in chosen])
    stations = []
    for path, waypoint in chosen:
        if waypoint.code not in current:
            found.problem("not-found", f"{waypoint.code} is not a station of the map", path)
        stations.append((path, current.get(waypoint.code, waypoint)))
    _stop_rules(stations[: len(pickups)], stations[len(pickups) :], found)
    chosen_pickups = [wp for _, wp in stations[: len(pickups)]]
    return site, chosen_pickups, [wp for _, wp in stations[len(pickups) :]]


def _station_key(reference, path: str, found: _Found):
    """("pk", 17) for Location/station-17, ("code", "1F-PHARM") for an identifier."""
    if reference.reference:
        pk = _id_number(reference.reference, f"Location/{STATION_PREFIX}")
        if pk is None:
            words = f"a station is Location/{STATION_PREFIX}<n>, or named by its identifier"
            found.problem("value", words, path)
        return ("pk", pk) if pk is not None else None
    identifier = reference.identifier
    if identifier is None or not identifier.value:
        words = "a Location reference, or an identifier with the station's code"
        found.problem("required", words, path)
        return None
    if identifier.system not in (None, codes.STATION_SYSTEM):
        found.problem("value", f"the station's identifier system is {codes.STATION_SYSTEM}", path)
        return None
    return ("code", identifier.value)


def _id_number(reference: str, prefix: str) -> int | None:
    if not reference.startswith(prefix):
        return None
    digits = reference[len(prefix) :]
    return int(digits) if digits.isdigit() and len(digits) < 12 else None


def _candidates(keys, sites) -> list[Waypoint]:
    """The stations the keys may name, on the user's sites."""
    pks = [value for kind, value in keys if kind == "pk"]
    names = [value for kind, value in keys if kind == "code"]
    rows = Waypoint.objects.filter(kind=WaypointKind.STATION).filter(
        Q(pk__in=pks) | Q(code__in=names)
    )
    if sites is not None:
        rows = rows.filter(site_id__in=sites)
    return list(rows.select_related("site"))


def _matches(key, waypoint: Waypoint) -> bool:
    kind, value = key
    return waypoint.pk == value if kind == "pk" else waypoint.code == value


def _site(resource, wanted, candidates, sites, found: _Found) -> Site | None:
    """Task.location's site if it names one, else the one site all the stations are on."""
    named = _named_site(resource, sites, found)
    possible = None if named is None else {named.pk}
    unresolved = False
    for path, key in wanted:
        if key is None:
            unresolved = True
            continue
        on = {wp.site_id for wp in candidates if _matches(key, wp)}
        if not on:
            found.problem("not-found", f"no such station ({_shown(key)})", path)
            unresolved = True
        elif possible is not None and not on & possible:
            where = "the site of Task.location" if named else "the Task's other stations"
            found.problem("invalid", f"this station is not on {where}", path)
            unresolved = True
        else:
            possible = on if possible is None else on & possible
    if unresolved or named is not None:
        return None if unresolved else named
    if len(possible) > 1:
        words = "these stations are on several sites: name the site in Task.location"
        found.problem("required", words, "Task.location")
        return None
    return next(wp.site for wp in candidates if wp.site_id in possible)


def _shown(key) -> str:
    kind, value = key
    return f"Location/{STATION_PREFIX}{value}" if kind == "pk" else f"code {value}"


def _named_site(resource, sites, found: _Found) -> Site | None:
    reference = resource.location
    if reference is None:
        return None
    rows = Site.objects.all() if sites is None else Site.objects.filter(pk__in=sites)
    if reference.reference:
        pk = _id_number(reference.reference, f"Location/{SITE_PREFIX}")
        site = rows.filter(pk=pk).first() if pk is not None else None
    elif reference.identifier is not None and reference.identifier.system in (
        None,
        codes.SITE_SYSTEM,
    ):
        site = rows.filter(code=reference.identifier.value).first()
    else:
        site = None
    if site is None:
        words = f"no such site: Location/{SITE_PREFIX}<n>, or the site's identifier"
        found.problem("not-found", words, "Task.location")
    return site


def _on_site(key, candidates, site: Site) -> Waypoint:
    return next(wp for wp in candidates if wp.site_id == site.pk and _matches(key, wp))


def _stop_rules(pickups, dropoffs, found: _Found) -> None:
    """No station twice, none both a pick-up and a drop-off, no many-to-many."""
    seen: set[int] = set()
    picked = {wp.pk for _, wp in pickups}
    for n, (path, waypoint) in enumerate((*pickups, *dropoffs)):
        if waypoint.pk in seen:
            found.problem("value", f"{waypoint.label} is given twice", path)
        elif n >= len(pickups) and waypoint.pk in picked:
            found.problem("value", f"{waypoint.label} is also a pickup", path)
        seen.add(waypoint.pk)
    if len(pickups) > 1 and len(dropoffs) > 1:
        words = "several pickups need exactly one dropoff (no many-to-many)"
        found.problem("value", words, "Task.input")
