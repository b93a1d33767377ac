"""What guessing a secure delivery's PIN from a robot's plan costs (docs/deployment/security.md,
"PINs"): the PBKDF2-HMAC-SHA256 iterations one core computes per second, and from it the core
time to try every code of a given length at a given iteration count.

    python bench/pin_guessing.py

It uses the same hashing as the server and the robots (hashlib's PBKDF2, OpenSSL), best of five
runs; an attacker's optimised code on a GPU is faster by the factor of their hardware, which
the "cores within an hour" column lets one read off.
"""

import argparse
import hashlib
import os
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving

RUNS = 5
CASES = [(6, 120_000), (6, 600_000), (8, 600_000), (10, 600_000)]


def iterations_per_second(iterations: int = 600_000) -> float:
    salt = os.urandom(16)
    best = float("inf")
    for _ in range(RUNS):
        start = time.perf_counter()
        hashlib.pbkdf2_hmac("sha256", b"12345678", salt, iterations)
        best = min(best, time.perf_counter() - start)
    return iterations / best


@saving.saves("pin_guessing")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    saving.add_argument(parser)
    parser.parse_args(argv)
    rate = iterations_per_second()
    print(f"one core: {rate:,.0f} PBKDF2-HMAC-SHA256 iterations/s (best of {RUNS})")
    print("digits  iterations  every code (core-hours)  on average  cores to find it in 1 h")
    for digits, iterations in CASES:
        hours = 10**digits * iterations / rate / 3600
        average = hours / 2  # also the cores that find it within an hour on average
        print(
            f"{digits:>6}  {iterations:>10,}  {hours:>23,.1f}  {average:>10,.1f}  {average:>8,.0f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
