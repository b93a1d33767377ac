"""Prometheus instruments of the resource controller (docs/deployment/monitoring.md): how long
robots waited for an elevator, door or corridor, observed when the grant is made."""

from prometheus_client import Histogram

LEASE_WAIT_SECONDS = Histogram(
    "hd_lease_wait_seconds",
    "Time from a robot's acquire request reaching the server to its grant, seconds",
    ["kind"],
    buckets=(0.1, 0.5, 1, 2.5, 5, 10, 30, 60, 120, 300, 600),
)


def lease_wait_observe(*, kind: str, seconds: float) -> None:
    LEASE_WAIT_SECONDS.labels(kind).observe(max(seconds, 0.0))
