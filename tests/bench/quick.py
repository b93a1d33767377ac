"""Running a benchmark's quick mode the way CI does."""

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def run_quick(script: str, *options: str, timeout: float = 300) -> str:
    """Run `python SCRIPT --quick [OPTIONS]` from the repository root; its output, or fail
    with it.

    The benchmark makes and drops a database of its own on the server of DATABASE_URL (the test
    settings' PostgreSQL) and uses the test Redis (REDIS_URL) with a queue of its own.
    """
    finished = subprocess.run(
        [sys.executable, script, "--quick", *options],
        cwd=ROOT,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    output = finished.stdout + finished.stderr
    assert finished.returncode == 0, output
    return finished.stdout


def cpu_samples(output: str, per: str) -> list[float]:
    """The samples of a CPU benchmark's "CPU ms per <per>: ..." line."""
    line = re.search(rf"CPU ms per {per}: ([\d. ]+)", output)
    return [float(sample) for sample in line.group(1).split()]
