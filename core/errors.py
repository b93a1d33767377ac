"""One error shape for the whole API: {"error": "<short code>", "detail": ...}.

Field errors are flattened to dotted paths ("state.battery", "events[2].type") so a client
always sees which field was wrong, however deeply it was nested.
"""

from django.core.exceptions import RequestDataTooBig
from rest_framework import exceptions, serializers, status
from rest_framework.response import Response
from rest_framework.views import exception_handler as drf_exception_handler

ERROR_CODES = {
    status.HTTP_400_BAD_REQUEST: "invalid",
    status.HTTP_401_UNAUTHORIZED: "unauthorized",
    status.HTTP_403_FORBIDDEN: "forbidden",
    status.HTTP_404_NOT_FOUND: "not_found",
    status.HTTP_405_METHOD_NOT_ALLOWED: "method_not_allowed",
    status.HTTP_409_CONFLICT: "conflict",
    status.HTTP_413_REQUEST_ENTITY_TOO_LARGE: "too_large",
    status.HTTP_415_UNSUPPORTED_MEDIA_TYPE: "unsupported_media_type",
}


def flatten_errors(detail, prefix: str = "") -> dict[str, list[str]]:
    """{"state": {"battery": ["x"]}, "events": {2: {"type": ["y"]}}}
    -> {"state.battery": ["x"], "events[2].type": ["y"]}"""
    if isinstance(detail, dict):
        flat: dict[str, list[str]] = {}
        for key, value in detail.items():
            if isinstance(key, int):
                path = f"{prefix}[{key}]"
            elif key == "non_field_errors":
                path = prefix or "body"
            else:
                path = f"{prefix}.{key}" if prefix else str(key)
            for name, messages in flatten_errors(value, path).items():
                flat.setdefault(name, []).extend(messages)
        return flat
    if isinstance(detail, list) and any(isinstance(item, dict | list) for item in detail):
        flat = {}
        for index, item in enumerate(detail):
            if item:
                flat.update(flatten_errors(item, f"{prefix}[{index}]"))
        return flat
    messages = detail if isinstance(detail, list) else [detail]
    return {prefix or "body": [printable(str(message)) for message in messages]}


def printable(text: str) -> str:
    """`text` without lone surrogates (shown as \\udxxx): messages may quote what a client sent,
    and the renderer cannot encode those."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


def error_response(code: str, detail, status_code: int, headers=None) -> Response:
    return Response({"error": code, "detail": detail}, status=status_code, headers=headers)


def exception_handler(exc, context):
    if isinstance(exc, RequestDataTooBig):
        # Over DATA_UPLOAD_MAX_MEMORY_SIZE: Django's own answer would be an HTML 400.
        return error_response(
            "too_large", {"body": [str(exc)]}, status.HTTP_413_REQUEST_ENTITY_TOO_LARGE
        )
    response = drf_exception_handler(exc, context)
    if response is None:
        return None
    if isinstance(exc, exceptions.ValidationError):
        detail = flatten_errors(exc.detail)
    elif isinstance(exc, exceptions.ParseError):
        return error_response("invalid_json", flatten_errors(exc.detail), response.status_code)
    else:
        # Django's Http404 and PermissionDenied carry no `detail`: DRF put theirs in the body.
        detail = printable(str(getattr(exc, "detail", None) or response.data["detail"]))
    code = ERROR_CODES.get(response.status_code, getattr(exc, "default_code", "error"))
    return error_response(code, detail, response.status_code, headers=dict(response.headers))


class ErrorSerializer(serializers.Serializer):
    error = serializers.CharField(help_text="short code: invalid, invalid_json, unauthorized, …")
    detail = serializers.JSONField(help_text="for field errors, {field path: [messages]}")
