"""bench/heartbeat_instructions.py --quick (plain heartbeats, and --delivery) runs to completion
in CI."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_counts_the_instructions_of_a_heartbeat():
    output = run_quick("bench/heartbeat_instructions.py", timeout=600)

    assert "20 heartbeats counted (after 20)" in output
    count = int(
        re.search(r"instructions per heartbeat: ([\d,]+)", output).group(1).replace(",", "")
    )
    assert 100_000 < count < 100_000_000  # a Python request: millions, not thousands or billions
    assert re.search(r"queries per heartbeat: \d+ \(BEGIN, SELECT robots_robot", output)
    # the robot found and locked, updated, its board read; SET LOCAL and COMMIT sent together
    trips = "5 (BEGIN, prepared, prepared, prepared, SET LOCAL synchronous_commit TO OFF; COMMIT)"
    assert f"round trips to PostgreSQL per heartbeat: {trips}" in output


def test_it_counts_the_instructions_of_a_delivery_cycle():
    output = run_quick("bench/heartbeat_instructions.py", "--delivery", timeout=600)

    assert "3 delivery cycles counted (after 5)" in output
    count = int(
        re.search(r"instructions per delivery cycle: ([\d,]+)", output).group(1).replace(",", "")
    )
    assert 1_000_000 < count < 1_000_000_000  # four requests, one allocating: tens of millions
    assert re.search(r"queries per delivery cycle: \d+ \(a request, three heartbeats\)", output)
