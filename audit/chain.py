"""The hash chain that makes the audit trail tamper-evident.

Each entry stores the SHA-256 of its own content together with the hash of the entry before it
(`previous_hash`). Changing any recorded field of a row, deleting a row from the middle, or
re-ordering rows breaks the chain at that row; the chain's head (one row holding the newest
hash) shows rows deleted from the end. `audit_verify` walks the chain and names the first entry
that does not match.

The hash covers what an auditor reads: kind, action, time, the actor's name, the address, the
site, the object and its before/after. The actor's user id is left out on purpose: deleting a
user sets it to NULL (the entry must survive its actor), and the name is kept in the entry.
"""

import hashlib
import json
from datetime import UTC

GENESIS = ""  # the previous hash of the first entry ever written


def content_of(entry) -> dict:
    return {
        "kind": entry.kind,
        "action": entry.action,
        "timestamp": entry.timestamp.astimezone(UTC).isoformat(),
        "actor": entry.actor_name,
        "address": entry.remote_addr or "",
        "site": entry.site_id,
        "content_type": entry.content_type_id,
        "object_pk": entry.object_pk,
        "object_repr": entry.object_repr,
        "changes": entry.changes,
        "changes_text": entry.changes_text,
        "additional_data": entry.additional_data,
        "previous": entry.previous_hash,
    }


def hash_of(entry) -> str:
    canonical = json.dumps(content_of(entry), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(canonical.encode()).hexdigest()
