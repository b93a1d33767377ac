"""bench/building_sweep.py --quick runs to completion in CI."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_measures_the_building_sweep():
    output = run_quick("bench/building_sweep.py")

    rows = re.findall(
        r"^\s+(\d+)\s+(at rest|a ride)\s+20\s+([\d.]+)\s+([\d.]+)\s+(\d+)$", output, re.M
    )
    assert [row[1] for row in rows] == ["at rest", "a ride"], output
    assert all(int(row[0]) >= 2 for row in rows)  # Eulji's elevator and door
    assert all(0 < float(row[2]) < 10_000 for row in rows)
