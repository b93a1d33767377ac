"""Percentiles read from histograms are PERCENTILE_CONT over the durations rounded to the
bucket, and histograms of days add up."""

import random

import pytest

from reports.histograms import figures_add, percentile
from tests.reports.test_reports import exact_percentile


def histogram(values, width):
    counts = {}
    for value in values:
        key = str(round(value / width))
        counts[key] = counts.get(key, 0) + 1
    return counts


@pytest.mark.parametrize("fraction", [0, 0.1, 0.5, 0.9, 1])
@pytest.mark.parametrize("n", [1, 2, 7, 500])
def test_it_is_the_continuous_percentile_of_the_rounded_values(n, fraction):
    rng = random.Random(n)
    values = [rng.lognormvariate(5, 1) for _ in range(n)]
    for width in (1.0, 0.1):
        rounded = [round(v / width) * width for v in values]
        got = percentile(histogram(values, width), fraction, width=width)
        assert got == pytest.approx(exact_percentile(rounded, fraction))
        assert abs(got - exact_percentile(values, fraction)) <= width / 2 + 1e-9


def test_an_empty_histogram_has_no_percentile():
    assert percentile({}, 0.5, width=1.0) is None
    assert percentile({"3": 0}, 0.5, width=1.0) is None


def test_days_add_up_key_by_key():
    monday = {
        "per_hour": {"9": 2},
        "by_priority": {"stat": {"deliveries": 1, "dropoff": {"60": 1}}},
    }
    tuesday = {
        "per_hour": {"9": 1, "10": 4},
        "by_priority": {"stat": {"deliveries": 2, "dropoff": {"60": 1, "90": 1}}},
    }
    total = figures_add(figures_add({}, monday), tuesday)
    assert total == {
        "per_hour": {"9": 3, "10": 4},
        "by_priority": {"stat": {"deliveries": 3, "dropoff": {"60": 2, "90": 1}}},
    }
    assert percentile(total["by_priority"]["stat"]["dropoff"], 0.5, width=1.0) == 60
