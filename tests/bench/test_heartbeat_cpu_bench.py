"""bench/heartbeat_cpu.py --quick runs to completion in CI."""

import re

import pytest

from tests.bench.quick import run_quick

pytestmark = pytest.mark.slow


def test_it_measures_the_cpu_time_of_a_heartbeat():
    output = run_quick("bench/heartbeat_cpu.py")

    assert "2 rounds of 100 heartbeats" in output
    samples = re.search(r"CPU ms per heartbeat: ([\d. ]+)", output).group(1).split()
    assert len(samples) == 2
    assert all(0 < float(sample) < 1000 for sample in samples)
