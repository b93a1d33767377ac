"""/fhir/r4/metadata: the CapabilityStatement, saying exactly what this server supports (the
search parameters listed are those fhir_r4.search reads)."""

from datetime import date

from fhir_r4 import codes

FHIR_VERSION = "4.0.1"
# When this statement last changed in meaning (CapabilityStatement.date is required).
STATEMENT_DATE = date(2026, 11, 28).isoformat()

_SEARCH = "http://hl7.org/fhir/SearchParameter"


def _param(name: str, kind: str, definition: str, documentation: str) -> dict:
    return {
        "name": name,
        "definition": f"{_SEARCH}/{definition}",
        "type": kind,
        "documentation": documentation,
    }


def _interactions(*codes_: str) -> list[dict]:
    return [{"code": code} for code in codes_]


TASK = {
    "type": "Task",
    "documentation": (
        "A delivery by robot. Create one with status requested, intent order, a pickup and a "
        f"dropoff input (types of {codes.INPUT_SYSTEM}) each a Location; update only to "
        "cancel it (status cancelled)."
    ),
    "interaction": _interactions("read", "vread", "update", "create", "search-type"),
    "versioning": "versioned-update",
    "readHistory": False,
    "updateCreate": False,
    "conditionalCreate": True,
    "conditionalRead": "not-match",
    "conditionalUpdate": False,
    "conditionalDelete": "not-supported",
    "searchParam": [
        _param("_id", "token", "Resource-id", "the Task's id, e.g. T-0042"),
        _param("_lastUpdated", "date", "Resource-lastUpdated", "eq, gt, ge, lt, le"),
        _param("status", "token", "Task-status", "requested, accepted, in-progress, ..."),
        _param("identifier", "token", "Task-identifier", "the order's, or ours (T-0042)"),
        _param("owner", "reference", "Task-owner", "the robot: Device/robot-<n>"),
        _param("focus", "reference", "Task-focus", "the order's reference, as sent"),
        _param("priority", "token", "Task-priority", "routine, urgent, asap, stat"),
    ],
}
LOCATION = {
    "type": "Location",
    "documentation": "Sites (Location/site-<n>) and their stations (Location/station-<n>).",
    "interaction": _interactions("read", "search-type"),
    "versioning": "no-version",
    "searchParam": [
        _param("_id", "token", "Resource-id", "site-<n> or station-<n>"),
        _param("identifier", "token", "Location-identifier", f"{codes.STATION_SYSTEM}|<code>"),
        _param("name", "string", "Location-name", "starts with, any case (name or code)"),
    ],
}
DEVICE = {
    "type": "Device",
    "documentation": "The robots, with their state as last reported.",
    "interaction": _interactions("read", "search-type"),
    "versioning": "no-version",
    "searchParam": [
        _param("_id", "token", "Resource-id", "robot-<n>"),
        _param("identifier", "token", "Device-identifier", f"{codes.ROBOT_SYSTEM}|<code>"),
        _param("device-name", "string", "Device-device-name", "starts with, any case"),
    ],
}


def capability_statement(base_url: str) -> dict:
    return {
        "resourceType": "CapabilityStatement",
        "status": "active",
        "date": STATEMENT_DATE,
        "publisher": "hospital_delivery",
        "kind": "instance",
        "software": {"name": "hospital_delivery"},
        "implementation": {
            "description": "Orders for delivery robots from hospital systems",
            "url": base_url,
        },
        "fhirVersion": FHIR_VERSION,
        "format": ["application/fhir+json", "json"],
        "rest": [
            {
                "mode": "server",
                "security": {
                    "description": (
                        "Authorization: Bearer <API token> of a staff user or of a user in "
                        "the integration group (manage.py user_token); each sees its sites."
                    )
                },
                "resource": [TASK, LOCATION, DEVICE],
            }
        ],
    }
