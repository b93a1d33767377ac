"""bench/heartbeat_cpu.py --quick runs to completion in CI."""

import os
import re

import pytest

from tests.bench.quick import cpu_samples, run_quick

pytestmark = pytest.mark.slow


def test_it_measures_the_cpu_time_of_a_heartbeat():
    output = run_quick("bench/heartbeat_cpu.py")

    assert "2 rounds of 100 heartbeats" in output
    samples = cpu_samples(output, "heartbeat")
    assert len(samples) == 2
    assert all(0 < sample < 1000 for sample in samples)
    wal = re.search(r"WAL bytes per heartbeat: median (\d+)", output)
    if os.environ.get("DATABASE_URL", "").startswith("postgres"):
        assert int(wal.group(1)) > 0  # every heartbeat writes its robot's row
