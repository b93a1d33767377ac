"""bench/latency.py --quick runs to completion in CI: every request reaches a robot."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_measures_every_row_with_and_without_push():
    output = run_quick("bench/latency.py")

    assert "latency benchmark" in output
    assert "lost" not in output
    rows = re.findall(r"^.{20}\s+(no|yes)\s+(\d+)\s+[\d.]+\s+[\d.]+\s+[\d.]+", output, re.MULTILINE)
    assert [push for push, _ in rows] == ["no", "yes"] * 2, output
    assert all(int(samples) > 0 for _, samples in rows)
