"""bench/reports.py --quick runs to completion in CI and times the page and every query."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_times_the_page_and_every_table_for_both_periods():
    output = run_quick("bench/reports.py")

    assert "reports benchmark" in output
    assert "3000 deliveries over 30 days" in output
    rows = re.findall(
        r"^(last 30 days|30 days)\s+(whole page|\S+)\s+([\d.]+)\s+(\d+)$", output, re.M
    )
    whats = [what for _, what, _, _ in rows]
    assert whats.count("whole page") == 2, output
    assert len(rows) == 2 * 8, output
    assert all(float(ms) > 0 for _, _, ms, _ in rows)
