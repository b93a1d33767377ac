"""bench/audit_cost.py --quick runs to completion in CI."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_measures_what_an_entry_adds_to_an_order_and_an_operator_action():
    output = run_quick("bench/audit_cost.py")

    assert "2 rounds of 10 of each, with and without the entry" in output
    rows = re.findall(r"^\| (nurse's order|operator's pause or resume)[^|]*\|(.*)$", output, re.M)
    assert [name for name, _ in rows] == ["nurse's order", "operator's pause or resume"]
    for _, cells in rows:
        without, with_entry, _added, queries_without, queries_with = (
            cell.strip() for cell in cells.strip(" |").split("|")
        )
        assert float(without) > 0
        assert float(with_entry) > 0
        # The chain's head locked, the entry inserted, the head moved on.
        assert float(queries_with) - float(queries_without) == 3
