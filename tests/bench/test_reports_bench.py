"""bench/reports.py --quick runs to completion in CI: rolls the days up and times the page, a
CSV and the figures (from the roll-ups and live) for both periods and today."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_times_the_page_and_the_figures_for_both_periods():
    output = run_quick("bench/reports.py")

    assert "reports benchmark" in output
    assert "3000 deliveries over 30 days" in output
    assert re.search(r"rolled up in [\d.]+ s: \d+ days stored", output), output
    rows = re.findall(
        r"^(last 30 days|30 days|today)\s+(whole page|by_ward.csv|figures, live|figures)"
        r"\s+([\d.]+)\s+(\d+)$",
        output,
        re.M,
    )
    whats = [what for _, what, _, _ in rows]
    assert whats.count("whole page") == 2, output
    assert len(rows) == 2 * 4 + 1, output
    assert all(float(ms) > 0 for _, _, ms, _ in rows)
