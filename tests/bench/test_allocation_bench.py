"""The benchmark's quick mode runs as CI would run it, and agrees with the brute force."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_quick_benchmark_agrees_with_enumeration_and_times_the_default_rule_and_a_burst():
    finished = subprocess.run(
        [sys.executable, "bench/allocation.py", "--quick"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert finished.returncode == 0, finished.stdout + finished.stderr
    agreed, compared = re.search(
        r"agreement with enumeration: (\d+)/(\d+)", finished.stdout
    ).groups()
    assert int(compared) > 0
    assert agreed == compared
    rows = re.findall(r"^\s+\d+\s+\d\s.*\s(\d+)/(\d+)\s", finished.stdout, re.MULTILINE)
    assert rows
    assert all(agreed == compared for agreed, compared in rows)

    rule = finished.stdout.split("the default rule (delivery_time)", 1)[1].split("a burst:")[0]
    timed = re.findall(r"^\s+(\d+)\s+(\d)\s+([\d.]+)ms\s+([\d.]+)ms$", rule, re.MULTILINE)
    assert [(robots, held) for robots, held, *_ in timed] == [
        (robots, held) for robots in ("3", "10") for held in ("1", "2", "3")
    ]
    assert all(0 < float(median) <= float(p90) for *_, median, p90 in timed)

    burst = finished.stdout.split("a burst: 20 tasks at once, 20 robots", 1)[1]
    lines = re.findall(
        r"^\s+(\d+)\s+(\d+)\s+([\d.]+)\s+[\d.]+\s+[\d.]+\s+(\d+)\s+(\d+)$", burst, re.M
    )
    assert [seed for seed, *_ in lines] == ["0", "1"]
    for _, _total, per_task, robots, most in lines:
        assert float(per_task) > 0
        assert 1 <= int(robots) <= 20
        # The 20 tasks on `robots` robots: at least this many on one of them.
        assert -(-20 // int(robots)) <= int(most) <= 20
