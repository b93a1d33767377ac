"""The FHIR endpoint's HTTP conventions on DRF's public switches: its media type
(application/fhir+json, application/json accepted too), `_format`, who may call it, and every
refusal as an OperationOutcome."""

from django.core.exceptions import RequestDataTooBig
from rest_framework import exceptions, permissions, renderers
from rest_framework.negotiation import DefaultContentNegotiation
from rest_framework.response import Response
from rest_framework.views import exception_handler as drf_exception_handler

from core.access import is_integration
from core.jsonbody import BoundedJSONParser
from fhir_r4.outcomes import FhirError, Issue, outcome

FHIR_JSON = "application/fhir+json"
# `_format` values we serve (FHIR's short names and MIME types); anything else is 406.
JSON_FORMATS = {"json", "application/json", FHIR_JSON, "application/json+fhir"}


class FhirJSONParser(BoundedJSONParser):
    """Bodies sent as application/fhir+json, bounded like every body of the API."""

    media_type = FHIR_JSON


class FhirJSONRenderer(renderers.JSONRenderer):
    media_type = FHIR_JSON


class FhirNegotiation(DefaultContentNegotiation):
    """`_format` first (as FHIR asks), then the Accept header; JSON only."""

    def select_renderer(self, request, renderers, format_suffix=None):
        wanted = request.query_params.get("_format")
        if wanted is not None:
            wanted = wanted.replace(" ", "+")  # a "+" in a query string reads as a space
            if wanted not in JSON_FORMATS:
                raise exceptions.NotAcceptable(f"_format={wanted}: this server speaks JSON only")
            json_too = wanted == "application/json"
            chosen = renderers[1] if json_too else renderers[0]
            return chosen, chosen.media_type
        return super().select_renderer(request, renderers, format_suffix)


class FhirAccess(permissions.BasePermission):
    """Staff users and users of the integration group (core.access), by API token or login."""

    message = "only the integration group and staff users may use the FHIR endpoint"

    def has_permission(self, request, view):
        if not (request.user and request.user.is_authenticated):
            return False
        return is_integration(request.user)


class FhirView:
    """Mixed into the endpoint's APIViews: its parsers, renderers and errors."""

    parser_classes = [FhirJSONParser, BoundedJSONParser]
    renderer_classes = [FhirJSONRenderer, renderers.JSONRenderer]
    content_negotiation_class = FhirNegotiation
    permission_classes = [FhirAccess]
    resource_type = "Resource"

    def get_exception_handler(self):
        return outcome_exception_handler


# DRF's refusals in FHIR's words (OperationOutcome.issue.code).
_CODES = {
    400: "structure",
    401: "login",
    403: "forbidden",
    404: "not-found",
    405: "not-supported",
    406: "not-supported",
    413: "too-long",
    415: "not-supported",
    429: "throttled",
}


def outcome_exception_handler(exc, context):
    """An OperationOutcome for every refusal; None (a 500) for what is not one."""
    if isinstance(exc, FhirError):
        return Response(outcome(exc.issues), status=exc.status, headers=exc.headers)
    if isinstance(exc, RequestDataTooBig):
        issue = Issue("too-long", str(exc))
        return Response(outcome([issue]), status=413)
    response = drf_exception_handler(exc, context)
    if response is None:
        return None
    resource_type = getattr(context.get("view"), "resource_type", "Resource")
    issues = _issues(exc, response.status_code, resource_type)
    headers = {k: v for k, v in response.headers.items() if k.lower() != "content-type"}
    return Response(outcome(issues), status=response.status_code, headers=headers)


def _issues(exc, status: int, resource_type: str) -> list[Issue]:
    code = _CODES.get(status, "processing")
    detail = exc.detail if isinstance(exc, exceptions.APIException) else str(exc)
    if isinstance(detail, dict):  # a body refused by its parser: {path: [why]}
        return [
            Issue(code, " ".join(map(str, why)), (_path(resource_type, path),))
            for path, why in detail.items()
        ]
    return [Issue(code, str(detail))]


def _path(resource_type: str, path: str) -> str:
    return resource_type if path == "body" else f"{resource_type}.{path}"
