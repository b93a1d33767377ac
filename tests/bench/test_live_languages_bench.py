"""bench/live_languages.py --quick runs to completion in CI and translates what it should."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_measures_the_payloads_in_one_and_in_every_language():
    output = run_quick("bench/live_languages.py")

    assert "2 rounds of 200 of each; languages: en, ko, it" in output
    rows = dict(re.findall(r"^\| (robot|task) [^|]*\|(.*)$", output, re.M))
    assert list(rows) == ["robot", "task"]
    cells = {
        name: [cell.strip() for cell in row.strip(" |").split("|")] for name, row in rows.items()
    }
    for one, every, _ratio, _fields in cells.values():
        assert 0 < float(one) < float(every)
    # Korean and Italian each: the robot's presence, status, floor and place; the task's status.
    assert (cells["robot"][3], cells["task"][3]) == ("8", "2")
