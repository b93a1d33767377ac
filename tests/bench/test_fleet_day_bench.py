"""bench/fleet_day.py --quick runs to completion in CI and prints both policies' figures."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_runs_a_short_day_under_both_policies():
    output = run_quick("bench/fleet_day.py")

    assert "fleet day benchmark" in output
    assert "command: python bench/fleet_day.py --quick" in output
    requested = re.search(r"^deliveries requested\s+(\d+)\s+(\d+)", output, re.MULTILINE)
    completed = re.search(r"^completed \(all\)\s+(\d+)\s+(\d+)", output, re.MULTILINE)
    assert requested, output
    assert completed, output
    assert requested.group(1) == requested.group(2) != "0"  # the same stream for both
    assert completed.groups() == requested.groups()
    for row in ("request -> drop-off, mean", "request -> drop-off, p90", "robot travel, distance"):
        assert re.search(rf"^{re.escape(row)}\s+\d+\.\d \w+\s+\d+\.\d \w+", output, re.MULTILINE)
