"""The Prometheus exposition at /metrics (docs/deployment/monitoring.md).

Two parts. Counters and histograms kept by the processes that do the work: heartbeats
(boards/metrics.py), allocations (scheduling/metrics.py), lease waits (resources/metrics.py);
under gunicorn and Celery, with PROMETHEUS_MULTIPROC_DIR set (run.sh), every process writes
them to files there and the scrape adds them up. Gauges of how things stand now, read from the
database and Redis at scrape time (reports/monitoring.py), so they hold whichever worker
answers.
"""

import os
from datetime import datetime

from prometheus_client import REGISTRY, CollectorRegistry, generate_latest
from prometheus_client.metrics_core import GaugeMetricFamily
from prometheus_client.multiprocess import MultiProcessCollector
from prometheus_client.registry import Collector

from reports import monitoring


def exposition(*, now: datetime, sites: frozenset[str] | None = None) -> bytes:
    """Every metric, in Prometheus' text format; the per-site series only of `sites` (codes)
    when given, those of every site when None."""
    state = CollectorRegistry(auto_describe=False)
    state.register(FleetCollector(now, sites))
    return _process_metrics() + generate_latest(state)


def _process_metrics() -> bytes:
    if not os.environ.get("PROMETHEUS_MULTIPROC_DIR"):
        return generate_latest(REGISTRY)  # one process (tests, runserver): its own figures
    registry = CollectorRegistry()
    MultiProcessCollector(registry)
    return generate_latest(registry)


class FleetCollector(Collector):
    """Gauges read at scrape time."""

    def __init__(self, now: datetime, sites: frozenset[str] | None = None):
        self.now = now
        self.sites = sites

    def _of_sites(self, rows: list[dict]) -> list[dict]:
        return rows if self.sites is None else [row for row in rows if row["site"] in self.sites]

    def collect(self):
        yield from self._robots()
        yield from self._tasks()
        yield from self._leases()
        yield from self._boards()
        yield from self._sweeps()
        yield from self._broker()

    def _robots(self):
        robots = _gauge("hd_robots", "Robots by presence and reported status", "presence", "status")
        for row in self._of_sites(monitoring.robots_by_state()):
            robots.add_metric([row["site"], row["presence"], row["status"]], row["n"])
        load = _gauge(
            "hd_robot_items_on_board",
            "Items a robot carries, with its presence",
            "robot",
            "presence",
        )
        offline = {}
        for row in self._of_sites(monitoring.robots_load()):
            load.add_metric([row["site"], row["code"], row["presence"]], row["load"])
            carrying = row["presence"] != "online" and row["load"] > 0
            offline[row["site"]] = offline.get(row["site"], 0) + carrying
        with_load = _gauge(
            "hd_robots_not_online_with_load",
            "Robots unreachable or offline with items on board",
        )
        for site, n in offline.items():
            with_load.add_metric([site], n)
        yield from (robots, load, with_load)

    def _tasks(self):
        tasks = _gauge("hd_tasks", "Delivery tasks by status", "status")
        for row in self._of_sites(monitoring.tasks_by_status()):
            tasks.add_metric([row["site"], row["status"]], row["n"])
        late = _gauge(
            "hd_tasks_past_due",
            "Deliveries not yet delivered past their own due time (due_at: the request's "
            "due_by, or its site's due time for its priority)",
            "priority",
        )
        for row in self._of_sites(monitoring.tasks_past_due(self.now)):
            late.add_metric([row["site"], row["priority"]], row["n"])
        yield from (tasks, late)

    def _leases(self):
        queued = _gauge("hd_lease_queue_length", "Robots queued for a resource", "resource", "kind")
        oldest = _gauge(
            "hd_lease_queue_oldest_wait_seconds",
            "How long the first robot in a resource's queue has waited",
            "resource",
            "kind",
        )
        for row in self._of_sites(monitoring.lease_queues(self.now)):
            labels = [row["site"], row["resource"], row["kind"]]
            queued.add_metric(labels, row["queued"])
            oldest.add_metric(labels, row["oldest_wait"])
        yield from (queued, oldest)

    def _boards(self):
        pending = _gauge("hd_board_messages_pending", "Board messages not yet acked by robots")
        oldest = _gauge(
            "hd_board_message_oldest_pending_seconds", "Age of the oldest unacked board message"
        )
        for row in self._of_sites(monitoring.board_pending(self.now)):
            pending.add_metric([row["site"]], row["pending"])
            oldest.add_metric([row["site"]], row["oldest_age"])
        yield from (pending, oldest)

    def _sweeps(self):
        lag = GaugeMetricFamily(
            "hd_sweep_lag_seconds",
            "How long ago the oldest deadline a sweep has not yet acted on passed (0: none)",
            labels=["sweep"],
        )
        for sweep, seconds in monitoring.sweep_lags(self.now).items():
            lag.add_metric([sweep], seconds)
        yield lag

    def _broker(self):
        broker = monitoring.broker_state()
        up = GaugeMetricFamily("hd_redis_up", "Whether Redis answered this scrape")
        up.add_metric([], 0 if broker is None else 1)
        yield up
        if broker is None:
            return
        depth = GaugeMetricFamily(
            "hd_celery_queue_length", "Celery messages waiting in the queue", labels=["queue"]
        )
        depth.add_metric([monitoring.celery_queue()], broker.queue_length)
        runs = GaugeMetricFamily(
            "hd_sweep_last_success_timestamp_seconds",
            "When each Celery beat sweep last finished successfully (Unix time)",
            labels=["task"],
        )
        for task, at in sorted(broker.sweeps_last_run.items()):
            runs.add_metric([task], at)
        yield from (depth, runs)


def _gauge(name: str, documentation: str, *labels: str) -> GaugeMetricFamily:
    return GaugeMetricFamily(name, documentation, labels=["site", *labels])
