"""Prometheus instruments of the VDA 5050 bridge (docs/deployment/monitoring.md): counted in the
bridge's own process (with PROMETHEUS_MULTIPROC_DIR set, into that directory, added up by
/metrics)."""

from prometheus_client import Counter

MESSAGES = Counter(
    "hd_vda5050_messages", "VDA 5050 messages the bridge received and applied, by topic", ["topic"]
)
REJECTED = Counter(
    "hd_vda5050_messages_rejected",
    "VDA 5050 messages the bridge dropped without changing anything, by topic and reason",
    ["topic", "reason"],
)


def message_applied(*, topic: str) -> None:
    MESSAGES.labels(topic).inc()


def message_rejected(*, topic: str, reason: str) -> None:
    REJECTED.labels(topic, reason).inc()
