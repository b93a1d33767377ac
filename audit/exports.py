"""An audit entry as auditors' files show it: a CSV row (through core.csvsafe, since names,
object descriptions and changes are typed by people) and a JSON object."""

import json

from django.utils import timezone

COLUMNS = [
    "entry",
    "time",
    "kind",
    "action",
    "actor",
    "address",
    "site",
    "object type",
    "object id",
    "object",
    "changes",
    "details",
    "previous hash",
    "hash",
]


def entry_record(entry) -> dict:
    return {
        "entry": entry.pk,
        "time": timezone.localtime(entry.timestamp).isoformat(),
        "kind": entry.kind,
        "action": entry.get_action_display(),
        "actor": entry.actor_name,
        "address": entry.remote_addr or "",
        "site": site_code(entry),
        "object type": entry.content_type.model if entry.content_type_id else "",
        "object id": entry.object_pk,
        "object": entry.object_repr,
        "changes": entry.changes,
        "details": entry.additional_data,
        "previous hash": entry.previous_hash,
        "hash": entry.entry_hash,
    }


def entry_row(entry) -> list:
    record = entry_record(entry)
    for name in ("changes", "details"):
        value = record[name]
        record[name] = "" if value is None else json.dumps(value, sort_keys=True)
    return [record[column] for column in COLUMNS]


def site_code(entry) -> str:
    if entry.site_id is None:
        return ""
    return entry.site.code if entry.site is not None else f"site {entry.site_id} (deleted)"
