"""The FHIR R4 endpoint, /fhir/r4/ (docs/integrators/fhir.md): thin views over
fhir_r4.orders (Task in), fhir_r4.services (writes), fhir_r4.selectors and .search (reads) and
fhir_r4.representation (resources out)."""

from urllib.parse import unquote, urlencode

from django.urls import reverse
from django.utils.http import http_date
from drf_spectacular.utils import extend_schema
from rest_framework import permissions
from rest_framework.response import Response
from rest_framework.views import APIView

from fhir_r4 import representation, search
from fhir_r4.capability import capability_statement
from fhir_r4.http import FhirView
from fhir_r4.orders import SITE_PREFIX, STATION_PREFIX, order_request
from fhir_r4.outcomes import FhirError
from fhir_r4.representation import ROBOT_PREFIX, etag, pin_output, task_resource
from fhir_r4.selectors import (
    orders_matching,
    robots_visible,
    sites_visible,
    stations_visible,
    task_visible,
    tasks_represented,
    tasks_visible,
)
from fhir_r4.services import order_cancel, order_create, orders_read_record
from fhir_r4.validation import resource_validated

SCHEMA = extend_schema(exclude=True)  # FHIR's own contract: /fhir/r4/metadata


@SCHEMA
class MetadataView(FhirView, APIView):
    """The CapabilityStatement: what this server supports, exactly. Open to anyone, as
    clients read it before they authenticate."""

    permission_classes = [permissions.AllowAny]
    resource_type = "CapabilityStatement"

    def get(self, request):
        base = request.build_absolute_uri(reverse("fhir-metadata")).rsplit("/metadata", 1)[0]
        return Response(capability_statement(base))


@SCHEMA
class TaskTypeView(FhirView, APIView):
    resource_type = "Task"

    def get(self, request):
        return _searchset(request, "Task", _task_rows(request), search.TASK_PARAMETERS)

    def post(self, request):
        resource = resource_validated(request.data, "Task")
        wanted = _if_none_exist(request, resource)
        if wanted is not None:
            found = orders_matching(request.user, *wanted)
            if len(found) > 1:
                words = "several Tasks match If-None-Exist"
                raise FhirError.one(412, "duplicate", words, "http.If-None-Exist")
            if found:
                return _task_answer(request, found[0], status=200)
        order = order_request(resource, user=request.user)
        task, created = order_create(user=request.user, order=order)
        if not created and wanted is None:
            words = f"a delivery with this identifier exists: Task/{task.code}"
            raise FhirError.one(409, "duplicate", words, "Task.identifier[0]")
        pin = getattr(task, "pin_plain", "") if created else ""
        return _task_answer(request, task, status=201 if created else 200, pin=pin)


@SCHEMA
class TaskInstanceView(FhirView, APIView):
    resource_type = "Task"

    def get(self, request, code):
        task = _task(request, code)
        if _not_modified(request, task.version):
            return Response(status=304, headers=_version_headers(task))
        return _task_answer(request, task)

    def put(self, request, code):
        """An update may only cancel: status `cancelled`, with an optional statusReason."""
        task = _task(request, code)
        resource = resource_validated(request.data, "Task")
        if resource.id != code:
            raise FhirError.one(400, "invalid", f"the body's id must be {code}", "Task.id")
        version = _if_match(request)
        if version is not None and version != task.version:
            words = f"the Task is at version {task.version}: read it again"
            raise FhirError.one(412, "conflict", words, "http.If-Match")
        if resource.status == representation.STATUSES[task.status]:
            return _task_answer(request, task)  # nothing asked that is not so already
        if resource.status != "cancelled":
            words = "an update may only cancel the delivery: status cancelled"
            raise FhirError.one(422, "business-rule", words, "Task.status")
        reason = resource.statusReason.text if resource.statusReason else ""
        order_cancel(user=request.user, task=task, version=version, reason=reason or "")
        return _task_answer(request, _task(request, code))


@SCHEMA
class TaskVersionView(FhirView, APIView):
    """vread: the current version only (the history keeps what happened, not each Task)."""

    resource_type = "Task"

    def get(self, request, code, version):
        task = _task(request, code)
        if str(task.version) != version:
            words = "only the current version of a Task is kept"
            raise FhirError.one(404, "not-found", words, "http.vid")
        return _task_answer(request, task)


@SCHEMA
class LocationTypeView(FhirView, APIView):
    resource_type = "Location"

    def get(self, request):
        sites = sites_visible(request.user).order_by("pk")
        stations = stations_visible(request.user).order_by("pk")
        wanted, filters = _parsed(request, search.STATION_PARAMETERS)
        site_wanted, site_filters = _parsed(request, search.SITE_PARAMETERS)
        rows = [
            (search.search_apply(sites, site_filters), representation.site_resource),
            (search.search_apply(stations, filters), representation.station_resource),
        ]
        return _bundle(request, "Location", wanted, rows)


@SCHEMA
class LocationInstanceView(FhirView, APIView):
    resource_type = "Location"

    def get(self, request, ident):
        if ident.startswith(SITE_PREFIX):
            site = sites_visible(request.user).filter(pk=_number(ident, SITE_PREFIX)).first()
            if site is not None:
                return Response(representation.site_resource(site))
        station = stations_visible(request.user).filter(pk=_number(ident, STATION_PREFIX))
        station = station.first() if ident.startswith(STATION_PREFIX) else None
        if station is None:
            raise FhirError.one(404, "not-found", f"no Location/{ident}")
        return Response(representation.station_resource(station))


@SCHEMA
class DeviceTypeView(FhirView, APIView):
    resource_type = "Device"

    def get(self, request):
        rows = robots_visible(request.user).order_by("pk")
        return _searchset(request, "Device", rows, search.DEVICE_PARAMETERS)


@SCHEMA
class DeviceInstanceView(FhirView, APIView):
    resource_type = "Device"

    def get(self, request, ident):
        robot = robots_visible(request.user).filter(pk=_number(ident, ROBOT_PREFIX)).first()
        if robot is None or not ident.startswith(ROBOT_PREFIX):
            raise FhirError.one(404, "not-found", f"no Device/{ident}")
        return Response(representation.device_resource(robot))


# --- Helpers --------------------------------------------------------------------------------


def _number(ident: str, prefix: str) -> int:
    digits = ident[len(prefix) :]
    return int(digits) if digits.isdigit() and len(digits) < 12 else 0


def _task(request, code: str):
    task = task_visible(request.user, code)
    if task is None:
        raise FhirError.one(404, "not-found", f"no Task/{code}")
    return task


def _task_rows(request):
    return tasks_represented(tasks_visible(request.user)).order_by("pk")


def _version_headers(task) -> dict:
    return {"ETag": etag(task.version), "Last-Modified": http_date(task.last_updated.timestamp())}


def _task_answer(request, task, *, status: int = 200, pin: str = "") -> Response:
    """The Task as it is now (read again: allocation may have moved it in the same request),
    with its version headers; the PIN of a new secure delivery, this once."""
    task = task_visible(request.user, task.code)
    headers = _version_headers(task)
    if status == 201:
        path = reverse("fhir-task-version", args=[task.code, task.version])
        headers["Location"] = request.build_absolute_uri(path)
    if request.headers.get("Prefer", "").replace(" ", "") == "return=minimal":
        return Response(status=status, headers=headers)
    resource = task_resource(task)
    orders_read_record(tasks=[task], via="FHIR read")
    if pin:
        resource["output"] = [*resource.get("output", []), pin_output(pin)]
    return Response(resource, status=status, headers=headers)


def _if_none_exist(request, resource) -> tuple[str | None, str] | None:
    """The identifier of a conditional create: the If-None-Exist header, or the same search
    as query parameters of the POST (as fhirpy sends it). The body must carry it."""
    query = request.headers.get("If-None-Exist")
    name = "http.If-None-Exist"
    if query is None and "identifier" in request.query_params:
        query, name = f"identifier={request.query_params['identifier']}", "http.identifier"
    if query is None:
        return None
    key, _, value = query.partition("=")
    if key.strip() != "identifier" or not value:
        raise FhirError.one(400, "not-supported", "only identifier=system|value", name)
    system, code = search.token(unquote(value.strip()))
    given = (resource.identifier or [None])[0]
    if given is None or given.value != code or (system and (given.system or "") != system):
        words = "the Task's identifier must be the one of its conditional create"
        raise FhirError.one(400, "invalid", words, "Task.identifier")
    return system or None, code


def _if_match(request) -> int | None:
    given = request.headers.get("If-Match")
    if given is None:
        return None
    text = given.strip().removeprefix("W/").strip('"')
    if not text.isdigit():
        raise FhirError.one(400, "value", 'a version as W/"3"', "http.If-Match")
    return int(text)


def _not_modified(request, version: int) -> bool:
    given = request.headers.get("If-None-Match")
    return given is not None and given.strip().removeprefix("W/").strip('"') == str(version)


def _parsed(request, supported: dict):
    strict = "handling=strict" in request.headers.get("Prefer", "").replace(" ", "")
    return search.search_parse(request.query_params, supported, strict=strict)


def _searchset(request, resource_type: str, rows, supported: dict) -> Response:
    wanted, filters = _parsed(request, supported)
    rows = search.search_apply(rows, filters)
    build = task_resource if resource_type == "Task" else representation.device_resource
    return _bundle(request, resource_type, wanted, [(rows, build)])


def _bundle(request, resource_type: str, wanted, parts) -> Response:
    """A searchset Bundle of one page of `parts` [(rows, resource builder)], in order, with
    its total and links (self, next, previous)."""
    totals = [rows.count() for rows, _ in parts]
    entries, start, room = [], wanted.offset, wanted.count
    for (rows, build), total in zip(parts, totals, strict=True):
        if room and start < total:
            page = list(rows[start : start + room])
            entries += [build(row) for row in page]
            if resource_type == "Task":
                orders_read_record(tasks=page, via="FHIR search")
            room -= len(page)
        start = max(0, start - total)
    base = request.build_absolute_uri(reverse("fhir-metadata")).rsplit("/metadata", 1)[0]
    bundle = {
        "resourceType": "Bundle",
        "type": "searchset",
        "total": sum(totals),
        "link": _links(base, resource_type, wanted, sum(totals)),
        "entry": [
            {
                "fullUrl": f"{base}/{entry['resourceType']}/{entry['id']}",
                "resource": entry,
                "search": {"mode": "match"},
            }
            for entry in entries
        ],
    }
    return Response(bundle)


def _links(base: str, resource_type: str, wanted, total: int) -> list[dict]:
    def url(offset: int) -> str:
        params = [*wanted.used, ("_count", wanted.count), ("_offset", offset)]
        return f"{base}/{resource_type}?{urlencode(params)}"

    links = [{"relation": "self", "url": url(wanted.offset)}]
    if wanted.count and wanted.offset + wanted.count < total:
        links.append({"relation": "next", "url": url(wanted.offset + wanted.count)})
    if wanted.offset:
        previous = max(0, wanted.offset - max(wanted.count, 1))
        links.append({"relation": "previous", "url": url(previous)})
    return links
