"""bench/fleet_day.py --quick runs to completion in CI and prints every policy's figures."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_runs_a_short_day_under_every_policy():
    output = run_quick("bench/fleet_day.py", timeout=900)  # four policies, a shared machine

    assert "fleet day benchmark" in output
    assert "command: python bench/fleet_day.py --quick" in output
    four = r"\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)"
    assert re.search(r"^\s+paper\s+least_travel\s+delivery_time\s+single$", output, re.MULTILINE)
    requested = re.search(rf"^deliveries requested{four}", output, re.MULTILINE)
    completed = re.search(rf"^completed \(all\){four}", output, re.MULTILINE)
    assert requested, output
    assert completed, output
    assert len(set(requested.groups())) == 1  # the same stream for every policy
    assert requested.group(1) != "0"
    assert completed.groups() == requested.groups()
    figure = r"\s+\d+\.\d \w+"
    for row in ("request -> drop-off, mean", "request -> drop-off, p90", "robot travel, distance"):
        assert re.search(rf"^{re.escape(row)}{figure * 4}", output, re.MULTILINE), output
