"""bench/heartbeat.py --quick runs to completion in CI against the production stack."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_loads_the_heartbeat_the_floor_and_the_bare_endpoint_pushes_plans_and_stalls_redis():
    output = run_quick("bench/heartbeat.py", "--floor")

    assert "heartbeat benchmark" in output
    rows = re.findall(
        r"^\s+(\d+)\s+(heartbeat|floor|bare \{\})\s+(\d+)\s+(\d+)\s+([\d.]+)\s+([\d.]+)\s+(\d+)",
        output,
        re.MULTILINE,
    )
    assert [(robots, endpoint) for robots, endpoint, *_ in rows] == [
        ("20", "heartbeat"),
        ("20", "floor"),
        ("20", "bare {}"),
    ], output
    assert all(int(achieved) > 0 for *_, achieved, _p50, _p99, _errors in rows)
    assert re.search(r"20 robots: [\d.]+ of the bare endpoint's throughput", output)
    assert re.search(r"20 robots, floor: [\d.]+ of the bare endpoint's throughput", output)
    # Plans posted to the push probes reached them during each heartbeat row.
    pushed = re.findall(r"^\s+\d+\s+heartbeat\s.*\s([\d.]+)\s+([\d.]+)(?:  \(|$)", output, re.M)
    assert len(pushed) == 1, output
    # The same load with Redis answering, then stalled: both rows answered.
    stalled = re.findall(r"^(answering|stalled)\s+(\d+)\s+([\d.]+)\s+([\d.]+)", output, re.M)
    assert [(name, int(achieved) > 0) for name, achieved, *_ in stalled] == [
        ("answering", True),
        ("stalled", True),
    ], output
