"""Incoming VDA 5050 messages checked against the standard's JSON schemas (vda5050/schemas/)."""

import json
from functools import cache
from pathlib import Path

from jsonschema import Draft202012Validator, FormatChecker

SCHEMAS = Path(__file__).resolve().parent / "schemas"
TOPICS = ("connection", "state", "factsheet", "order", "instantActions")


class MessageInvalid(Exception):
    """A message the bridge drops: `reason` is the counter's label, `detail` for the log."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail


@cache
def validator(topic: str) -> Draft202012Validator:
    schema = json.loads((SCHEMAS / f"{topic}.schema.json").read_text(encoding="utf-8"))
    return Draft202012Validator(schema, format_checker=FormatChecker())


def message_parse(topic: str, payload: bytes) -> dict:
    """The payload as a dict that satisfies the topic's schema, or MessageInvalid."""
    try:
        message = json.loads(payload.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise MessageInvalid("invalid_json", str(exc)[:200]) from None
    errors = sorted(validator(topic).iter_errors(message), key=lambda e: list(e.absolute_path))
    if errors:
        where = "/".join(str(part) for part in errors[0].absolute_path) or "(message)"
        raise MessageInvalid("schema", f"{where}: {errors[0].message[:200]}")
    return message
