"""bench/heartbeat_cpu.py --quick runs to completion in CI."""

import os
import re

import pytest

from tests.bench.quick import cpu_samples, run_quick

pytestmark = pytest.mark.slow


def test_it_measures_the_cpu_time_of_a_heartbeat_and_on_postgresql_of_the_floor():
    postgres = os.environ.get("DATABASE_URL", "").startswith("postgres")
    output = run_quick("bench/heartbeat_cpu.py", *(["--floor"] if postgres else []))

    assert "2 rounds of 100 heartbeats" in output
    samples = cpu_samples(output, "heartbeat")
    assert len(samples) == 2
    assert all(0 < sample < 1000 for sample in samples)
    if postgres:
        wal = re.search(r"WAL bytes per heartbeat: median (\d+)", output)
        assert int(wal.group(1)) > 0  # every heartbeat writes its robot's row
        for endpoint in ("floor", "bare"):
            compared = cpu_samples(output, f"{endpoint} request")
            assert len(compared) == 2, output
            assert all(0 < sample < 1000 for sample in compared)
