"""The one JSON parser for request bodies: the robot heartbeat and the REST API.

`json.loads` alone lets hostile bodies through to places that fail with a 500: deep nesting
(`[` x 3000 raises RecursionError), lone surrogates ("\\ud800" is valid JSON but not Unicode: the
database and the renderer cannot encode it) and NUL characters (PostgreSQL stores none). This
module refuses them at the door, naming where in the body they are; numbers too large for the
database are bounded by the fields (hospital_delivery/fields.py).
"""

import json

from rest_framework import exceptions, parsers

# Valid heartbeats and API bodies nest 4 levels; 32 leaves room for robots' extra fields.
MAX_DEPTH = 32
# REST API bodies (a task request is well under 1 KiB); the heartbeat has its own limit.
API_MAX_BYTES = 256 * 1024


class PayloadTooLarge(exceptions.APIException):
    status_code = 413
    default_detail = "request body is over the limit"
    default_code = "too_large"


class BodyInvalid(exceptions.ParseError):
    """A body that is not JSON we can handle; `detail` is {field path: [why]}."""

    def __init__(self, path: str, why: str):
        super().__init__({path or "body": [why]})


def json_parse(raw: bytes):
    """`raw` parsed as JSON, or BodyInvalid naming where it goes wrong."""
    # Brackets are counted before parsing: json.loads recurses once per level.
    _check_nesting(raw)
    try:
        data = json.loads(raw)
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise BodyInvalid("body", f"body is not valid UTF-8 JSON: {_safe(str(exc))}") from None
    _check_text(data, "")
    return data


def _check_nesting(raw: bytes) -> None:
    """Refuse bodies nested deeper than MAX_DEPTH, without parsing them."""
    # Brackets inside strings do not nest; outside them only [ ] { } change depth. A quick
    # scan of the structural bytes only, skipping strings (and their escaped quotes).
    depth = 0
    in_string = escaped = False
    for byte in raw:
        if in_string:
            if escaped:
                escaped = False
            elif byte == 0x5C:  # backslash
                escaped = True
            elif byte == 0x22:  # "
                in_string = False
        elif byte == 0x22:
            in_string = True
        elif byte in (0x5B, 0x7B):  # [ {
            depth += 1
            if depth > MAX_DEPTH:
                raise BodyInvalid("body", f"nested deeper than {MAX_DEPTH} levels")
        elif byte in (0x5D, 0x7D):  # ] }
            depth -= 1


def _check_text(value, path: str) -> None:
    """Refuse strings (values or keys) that are not Unicode text, naming the first one."""
    if isinstance(value, str):
        if not _is_text(value):
            raise BodyInvalid(path, "not valid Unicode text (lone surrogate or NUL)")
    elif isinstance(value, dict):
        for key, item in value.items():
            child = f"{path}.{_safe(key)}" if path else _safe(key)
            if not _is_text(key):
                raise BodyInvalid(child, "key is not valid Unicode text (lone surrogate or NUL)")
            _check_text(item, child)
    elif isinstance(value, list):
        for index, item in enumerate(value):
            _check_text(item, f"{path}[{index}]")


def _is_text(text: str) -> bool:
    # PostgreSQL stores neither NUL nor lone surrogates, in text or in jsonb.
    if "\x00" in text:
        return False
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _safe(text: str) -> str:
    """`text` made encodable: lone surrogates shown as \\udxxx escapes, never echoed raw."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


class BoundedJSONParser(parsers.JSONParser):
    """DRF's JSON parser with the size limit, depth bound and text check above."""

    def parse(self, stream, media_type=None, parser_context=None):
        raw = stream.read(API_MAX_BYTES + 1) if stream is not None else b""
        if len(raw) > API_MAX_BYTES:
            raise PayloadTooLarge(f"body is over the {API_MAX_BYTES}-byte limit")
        return json_parse(raw)
