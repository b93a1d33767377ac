"""FHIR date search values cover a range as wide as their precision (no database)."""

from datetime import UTC, datetime, timedelta, timezone

import pytest

from fhir_r4.search import date_range, reference_id, token

SEOUL = timezone(timedelta(hours=9))


@pytest.mark.parametrize(
    ("value", "prefix", "start", "end"),
    [
        ("2026", "eq", datetime(2026, 1, 1, tzinfo=UTC), datetime(2027, 1, 1, tzinfo=UTC)),
        ("gt2026-12", "gt", datetime(2026, 12, 1, tzinfo=UTC), datetime(2027, 1, 1, tzinfo=UTC)),
        (
            "le2026-11-22",
            "le",
            datetime(2026, 11, 22, tzinfo=UTC),
            datetime(2026, 11, 23, tzinfo=UTC),
        ),
        (
            "lt2026-11-22T09:14+09:00",
            "lt",
            datetime(2026, 11, 22, 9, 14, tzinfo=SEOUL),
            datetime(2026, 11, 22, 9, 15, tzinfo=SEOUL),
        ),
        (
            "gt2026-11-22T09:14:03Z",
            "gt",
            datetime(2026, 11, 22, 9, 14, 3, tzinfo=UTC),
            datetime(2026, 11, 22, 9, 14, 4, tzinfo=UTC),
        ),
        (
            "ge2026-11-22T09:14:03.120456+00:00",
            "ge",
            datetime(2026, 11, 22, 9, 14, 3, 120456, tzinfo=UTC),
            datetime(2026, 11, 22, 9, 14, 3, 120457, tzinfo=UTC),
        ),
    ],
)
def test_a_date_value_covers_its_precision(value, prefix, start, end):
    assert date_range(value) == (prefix, start, end)


@pytest.mark.parametrize(
    "value", ["yesterday", "2026-13-01", "2026-11-22T09:14", "ne2026", "2026-02-30"]
)
def test_it_refuses_what_is_no_date_or_no_comparison_it_makes(value):
    with pytest.raises(ValueError, match=r"dateTime|exists|prefix"):
        date_range(value)


def test_tokens_and_references():
    assert token("http://x|RX-1") == ("http://x", "RX-1")
    assert token("|RX-1") == ("", "RX-1")
    assert token("RX-1") == (None, "RX-1")
    assert reference_id("Device/robot-3", "Device", "robot-") == 3
    assert reference_id("http://h/fhir/r4/Device/robot-3", "Device", "robot-") == 3
    assert reference_id("robot-3", "Device", "robot-") == 3
    assert reference_id("Location/robot-3", "Device", "robot-") is None
