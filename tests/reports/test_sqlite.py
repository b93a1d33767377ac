"""The reports on SQLite, the embedded default: the same database aggregation (durations by
julianday, histograms rounded by the database) and the percentiles read from the histograms,
live and from the daily roll-ups, in a subprocess on a migrated SQLite file."""

import json
import os
import subprocess
import sys

import pytest

from tests import servers

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    database = tmp_path_factory.mktemp("sqlite") / "db.sqlite3"
    env = {**os.environ, "DATABASE_URL": f"sqlite:///{database}"}
    run = {"cwd": servers.REPO, "env": env, "check": True, "timeout": 300}
    subprocess.run([sys.executable, "manage.py", "migrate", "--noinput", "-v", "0"], **run)
    script = servers.REPO / "tests" / "reports" / "sqlite_reports.py"
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, **run)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_it_runs_on_sqlite_and_reads_the_same_rows_from_the_roll_ups(report):
    assert report["vendor"] == "sqlite"
    assert report["rolled"] == report["live"]
    assert sum(row["deliveries"] for row in report["live"]["per_day"]) > 0
    assert all(row["moving_h"] > 0 for row in report["live"]["utilisation"])


def test_its_percentiles_are_python_s_over_the_rounded_durations(report):
    by_priority = {row["priority"]: row for row in report["live"]["by_priority"]}
    assert set(by_priority) == set(report["expected"]["dropoff"])
    for priority, (p50, p90) in report["expected"]["dropoff"].items():
        assert by_priority[priority]["dropoff_p50_min"] == round(p50, 1)
        assert by_priority[priority]["dropoff_p90_min"] == round(p90, 1)
    waits = {row["resource"]: row for row in report["live"]["resource_waits"]}
    assert set(waits) == set(report["expected"]["wait"])
    for code, (p50, p90) in report["expected"]["wait"].items():
        assert waits[code]["wait_p50_s"] == round(p50, 1)
        assert waits[code]["wait_p90_s"] == round(p90, 1)
