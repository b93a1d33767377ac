"""bench/request_cpu.py --quick runs to completion in CI."""

import re

import pytest

from tests.bench.quick import cpu_samples, run_quick

pytestmark = pytest.mark.slow


def test_it_measures_the_cpu_time_of_a_delivery_request():
    output = run_quick("bench/request_cpu.py")

    assert "2 rounds of 20 requests" in output
    samples = cpu_samples(output, "request")
    assert len(samples) == 2
    assert all(0 < sample < 1000 for sample in samples)
    # The token, the site; BEGIN, the task, its stops, its history entry, its audit entry (the
    # chain's head locked, the entry, the head moved on), the webhooks to tell, COMMIT; the
    # answer's stops and history read back (scheduling.selectors.task_detail_of). The stations
    # come from the cached map.
    assert re.search(r"queries per request: (\d+)", output).group(1) == "13"


def test_it_measures_a_request_allocated_in_the_request():
    output = run_quick("bench/request_cpu.py", "--allocating")

    assert "each allocated in the request to the one robot" in output
    samples = cpu_samples(output, "request")
    assert len(samples) == 2
    assert all(0 < sample < 1000 for sample in samples)
    # Those above, and within them the allocation: a savepoint, the site's lock, the robots
    # and their routes, the chosen robot locked and its route read again, its last plan, the
    # plan posted and stored, the ETAs, the claim and the robot's count of tasks given (the
    # allocator's tie-break), its history entry, the release; the site's webhooks are read
    # once for both history entries (core.memo).
    assert re.search(r"queries per request: (\d+)", output).group(1) == "27"
