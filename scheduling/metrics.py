"""Prometheus instruments of the scheduler (docs/deployment/monitoring.md): how long choosing a
robot and its route takes, in the web worker (allocation in the request) or the Celery worker."""

from prometheus_client import Histogram

ALLOCATION_SECONDS = Histogram(
    "hd_allocation_seconds",
    "Time to allocate one task (choose the robot and its route, post the plan), seconds",
    buckets=(0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0),
)
