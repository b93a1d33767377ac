"""How a webhook request is signed, and how a receiver checks it (docs/integrators/webhooks.md).

    X-Webhook-Timestamp: 1795420800
    X-Webhook-Signature: sha256=<hex HMAC-SHA256(secret, "<timestamp>." + body)>

The timestamp is inside the signature, so a receiver that refuses old timestamps (say, more
than five minutes away from its clock) cannot be replayed a captured request later.
"""

import hashlib
import hmac

SIGNATURE_HEADER = "X-Webhook-Signature"
TIMESTAMP_HEADER = "X-Webhook-Timestamp"
EVENT_ID_HEADER = "X-Webhook-Id"


def signature(secret: str, timestamp: int, body: bytes) -> str:
    digest = hmac.new(secret.encode(), f"{timestamp}.".encode() + body, hashlib.sha256)
    return f"sha256={digest.hexdigest()}"


def signature_valid(secret: str, *, timestamp: str, body: bytes, signed: str) -> bool:
    """For receivers (and the tests): whether `signed` is this body's signature."""
    if not timestamp.isdigit():
        return False
    return hmac.compare_digest(signature(secret, int(timestamp), body), signed)
