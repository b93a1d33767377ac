"""Prometheus instruments of the heartbeat, the hot path (docs/deployment/monitoring.md).

Counted and timed in the web worker that answers; with PROMETHEUS_MULTIPROC_DIR set (run.sh),
each gunicorn worker writes its figures to a memory-mapped file there and the scrape adds
them up (reports/metrics.py). One counter increment and one histogram observation per
heartbeat: a few microseconds, no query, no network.
"""

from prometheus_client import Counter, Gauge, Histogram

HEARTBEATS = Counter("hd_heartbeats", "Robot heartbeats answered, by HTTP status code", ["code"])
HEARTBEAT_SECONDS = Histogram(
    "hd_heartbeat_seconds",
    "Time to answer a robot heartbeat (authentication to response), seconds",
    buckets=(0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0),
)

HEARTBEAT_INTERVAL_TOLD = Gauge(
    "hd_heartbeat_interval_told_seconds",
    "The heartbeat_interval last told to a robot (longer than the site's under load)",
    multiprocess_mode="livemax",
)


def heartbeat_observe(*, status_code: int, seconds: float) -> None:
    HEARTBEATS.labels(str(status_code)).inc()
    HEARTBEAT_SECONDS.observe(seconds)


def heartbeat_interval_told_observe(seconds: float) -> None:
    HEARTBEAT_INTERVAL_TOLD.set(seconds)
