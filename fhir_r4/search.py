"""FHIR search parameters of our resources, parsed into querysets (docs/integrators/fhir.md,
"Searching"). A value we cannot read is refused (400, naming `http.<parameter>`); a parameter
we do not support is ignored and left out of the Bundle's self link, as FHIR asks, or refused
under `Prefer: handling=strict`."""

import re
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from datetime import timezone as fixed_offset

from django.db.models import Q, QuerySet

from fhir_r4 import codes
from fhir_r4.orders import PRIORITIES, SITE_PREFIX, STATION_PREFIX
from fhir_r4.outcomes import FhirError
from fhir_r4.representation import FHIR_PRIORITY, ROBOT_PREFIX, STATUSES_OF
from scheduling.models import TaskTransition, task_pk

DEFAULT_COUNT = 50
MAX_COUNT = 200
# Parameters about the answer rather than the matches: kept in paging links, never filters.
RESULT_PARAMETERS = ("_count", "_offset", "_format")
_PREFIXES = ("eq", "ne", "gt", "lt", "ge", "le", "sa", "eb")
# A FHIR dateTime to any precision: year, month, day, minute, second, fraction; zone needed
# with a time.
_DATE = re.compile(
    r"(?P<y>\d{4})(-(?P<m>\d{2})(-(?P<d>\d{2})(T(?P<H>\d{2}):(?P<M>\d{2})"
    r"(:(?P<S>\d{2})(?P<f>\.\d{1,6})?)?(?P<z>Z|[+-]\d{2}:\d{2}))?)?)?"
)


@dataclass
class Search:
    """The parameters used (for the self link) and the page asked for."""

    used: list[tuple[str, str]] = field(default_factory=list)
    count: int = DEFAULT_COUNT
    offset: int = 0


def search_parse(params, supported: dict, *, strict: bool) -> tuple[Search, list]:
    """(Search, [(filter function, value, name)]) of the query parameters `params` (a
    QueryDict) for a resource whose parameters are `supported` {name: filter function}."""
    search, filters = Search(), []
    for name, values in params.lists():
        if name in RESULT_PARAMETERS:
            continue
        base = name.split(":", 1)[0]
        apply = supported.get(name) or (supported.get(base) if ":" not in name else None)
        if apply is None:
            if strict:
                words = "not a search parameter here"
                raise FhirError.one(400, "not-supported", words, f"http.{name}")
            continue
        for value in values:
            filters.append((apply, value, name))
            search.used.append((name, value))
    search.count = _number(params, "_count", DEFAULT_COUNT, 0, MAX_COUNT)
    search.offset = _number(params, "_offset", 0, 0, 10**9)
    return search, filters


def search_apply(rows: QuerySet, filters) -> QuerySet:
    for apply, value, name in filters:
        try:
            rows = apply(rows, value)
        except ValueError as why:
            raise FhirError.one(400, "value", str(why), f"http.{name}") from None
    return rows


def _number(params, name: str, default: int, low: int, high: int) -> int:
    text = params.get(name)
    if text is None:
        return default
    if not text.isdigit() or not low <= int(text) <= high:
        raise FhirError.one(400, "value", f"a whole number from {low} to {high}", f"http.{name}")
    return int(text)


# --- Value types ----------------------------------------------------------------------------


def _any_of(value: str) -> list[str]:
    """A comma separates alternatives (OR); \\, is a comma in a value."""
    parts = re.split(r"(?<!\\),", value)
    return [part.replace("\\,", ",") for part in parts]


def token(value: str) -> tuple[str | None, str]:
    """`system|code`, `|code` (no system), `code` (any system) -> (system or "" or None, code)."""
    if "|" not in value:
        return None, value
    system, code = value.split("|", 1)
    return system, code


def date_range(value: str) -> tuple[str, datetime, datetime]:
    """(prefix, start, end) of a date search value, its range as wide as its precision."""
    prefix = value[:2] if value[:2] in _PREFIXES else "eq"
    text = value[2:] if value[:2] in _PREFIXES else value
    if prefix not in ("eq", "gt", "lt", "ge", "le"):
        raise ValueError("use the prefix eq, gt, lt, ge or le")
    match = _DATE.fullmatch(text)
    if match is None:
        raise ValueError("a FHIR dateTime: YYYY-MM-DDThh:mm:ss+zz:zz, or less precise")
    parts = match.groupdict()
    start, step = _start(parts)
    return prefix, start, _after(start, step)


def _start(parts: dict) -> tuple[datetime, str]:
    zone = parts["z"]
    tz = UTC
    if zone and zone != "Z":
        sign = 1 if zone[0] == "+" else -1
        tz_offset = timedelta(hours=int(zone[1:3]), minutes=int(zone[4:6])) * sign
        tz = fixed_offset(tz_offset)
    fraction = parts["f"] or ""
    micro = int((fraction[1:] + "000000")[:6]) if fraction else 0
    fields = [int(parts[key] or default) for key, default in (("y", 1), ("m", 1), ("d", 1))]
    fields += [int(parts[key] or 0) for key in ("H", "M", "S")]
    try:
        start = datetime(*fields, micro, tzinfo=tz)
    except ValueError:
        raise ValueError("not a date that exists") from None
    step = next(
        (name for name, key in (("year", "m"), ("month", "d"), ("day", "H")) if not parts[key]),
        None,
    )
    if step is None and not parts["S"]:
        step = "minute"
    elif step is None:
        step = f"f{len(fraction) - 1}" if fraction else "second"
    return start, step


def _after(start: datetime, step: str) -> datetime:
    if step == "year":
        return start.replace(year=start.year + 1)
    if step == "month":
        return start.replace(year=start.year + start.month // 12, month=start.month % 12 + 1)
    if step.startswith("f"):
        return start + timedelta(microseconds=10 ** (6 - int(step[1:])))
    sizes = {"day": timedelta(days=1), "minute": timedelta(minutes=1)}
    return start + sizes.get(step, timedelta(seconds=1))


def moment_matches(field_name: str, value: str) -> Q:
    """A Q on a datetime field for one date search value: ranges as FHIR compares them."""
    prefix, start, end = date_range(value)
    return {
        "eq": Q(**{f"{field_name}__gte": start, f"{field_name}__lt": end}),
        "gt": Q(**{f"{field_name}__gte": end}),
        "ge": Q(**{f"{field_name}__gte": start}),
        "lt": Q(**{f"{field_name}__lt": start}),
        "le": Q(**{f"{field_name}__lt": end}),
    }[prefix]


def reference_id(value: str, resource_type: str, prefix: str) -> int | None:
    """The number of `Device/robot-3`, `robot-3` or a full URL ending in one; None if not ours."""
    tail = value.rstrip("/").rsplit("/", 2)
    given = tail[-1]
    if len(tail) > 1 and tail[-2] != resource_type:
        return None
    if not given.startswith(prefix) or not given[len(prefix) :].isdigit():
        return None
    return int(given[len(prefix) :])


# --- Task -----------------------------------------------------------------------------------


def _task_status(rows, value):
    wanted = []
    for status in _any_of(value):
        if status not in STATUSES_OF:
            known = ", ".join(sorted(STATUSES_OF))
            raise ValueError(f"{status!r}: our Tasks are {known}")
        wanted += STATUSES_OF[status]
    return rows.filter(status__in=wanted)


def _task_identifier(rows, value):
    matches = Q(pk__in=[])
    for system, code in map(token, _any_of(value)):
        if system in (None, codes.TASK_CODE_SYSTEM):
            matches |= Q(pk=task_pk(code) or 0)
        if system != codes.TASK_CODE_SYSTEM:
            ordered = Q(fhir_order__identifier_value=code)
            if system is not None:
                ordered &= Q(fhir_order__identifier_system=system)
            matches |= ordered
    return rows.filter(matches)


def _task_last_updated(rows, value):
    """Changed in the range: tasks with a history entry in it (gt, ge: an index on the
    entries' time), or whose newest entry is in it."""
    prefix, _, _ = date_range(value)
    if prefix in ("gt", "ge"):
        changed = TaskTransition.objects.filter(moment_matches("at", value))
        return rows.filter(pk__in=changed.values("task_id"))
    return rows.filter(moment_matches("last_updated", value))


def _task_owner(rows, value):
    pks = [reference_id(ref, "Device", ROBOT_PREFIX) for ref in _any_of(value)]
    return rows.filter(robot_id__in=[pk for pk in pks if pk is not None])


def _task_focus(rows, value):
    return rows.filter(fhir_order__focus__reference__in=_any_of(value))


def _task_focus_identifier(rows, value):
    return rows.filter(_order_identifier_matches("focus", value))


def _task_for_identifier(rows, value):
    return rows.filter(_order_identifier_matches("beneficiary", value))


def _order_identifier_matches(element: str, value: str) -> Q:
    matches = Q(pk__in=[])
    for system, code in map(token, _any_of(value)):
        one = Q(**{f"fhir_order__{element}__identifier__value": code})
        if system:
            one &= Q(**{f"fhir_order__{element}__identifier__system": system})
        matches |= one
    return matches


def _task_priority(rows, value):
    matches = Q(pk__in=[])
    for fhir in _any_of(value):
        if fhir not in PRIORITIES:
            raise ValueError("use routine, urgent, asap or stat")
        ours = [p for p, name in FHIR_PRIORITY.items() if name == fhir]
        matches |= Q(fhir_order__priority=fhir) | Q(fhir_order__isnull=True, priority__in=ours)
    return rows.filter(matches)


def _by_id(prefix: str):
    def apply(rows, value):
        ids = [value[len(prefix) :] for value in _any_of(value) if value.startswith(prefix)]
        return rows.filter(pk__in=[int(i) for i in ids if i.isdigit() and len(i) < 12])

    return apply


def _task_id(rows, value):
    return rows.filter(pk__in=[task_pk(code) or 0 for code in _any_of(value)])


TASK_PARAMETERS = {
    "_id": _task_id,
    "status": _task_status,
    "identifier": _task_identifier,
    "_lastUpdated": _task_last_updated,
    "owner": _task_owner,
    "focus": _task_focus,
    "focus:identifier": _task_focus_identifier,
    "patient:identifier": _task_for_identifier,
    "subject:identifier": _task_for_identifier,
    "priority": _task_priority,
}


# --- Location and Device --------------------------------------------------------------------


def _identifier_of(system_wanted: str, field_name: str = "code"):
    def apply(rows, value):
        matches = Q(pk__in=[])
        for system, code in map(token, _any_of(value)):
            if system in (None, system_wanted):
                matches |= Q(**{field_name: code})
        return rows.filter(matches)

    return apply


def _name_starts(*fields: str):
    """FHIR string search: starts with, ignoring case, on any of `fields`."""

    def apply(rows, value):
        matches = Q(pk__in=[])
        for text in _any_of(value):
            for name in fields:
                matches |= Q(**{f"{name}__istartswith": text})
        return rows.filter(matches)

    return apply


STATION_PARAMETERS = {
    "_id": _by_id(STATION_PREFIX),
    "identifier": _identifier_of(codes.STATION_SYSTEM),
    "name": _name_starts("name", "code"),
}
SITE_PARAMETERS = {
    "_id": _by_id(SITE_PREFIX),
    "identifier": _identifier_of(codes.SITE_SYSTEM),
    "name": _name_starts("name", "code"),
}
DEVICE_PARAMETERS = {
    "_id": _by_id(ROBOT_PREFIX),
    "identifier": _identifier_of(codes.ROBOT_SYSTEM),
    "device-name": _name_starts("name", "code"),
}
