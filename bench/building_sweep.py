"""What the building sweep costs: the simulated lifts and doors advanced every second.

    python bench/building_sweep.py            # 200 sweeps at rest, 200 with the lift riding
    python bench/building_sweep.py --quick    # 20 and 20: what CI runs

The Eulji site, every elevator and door given a simulated device (building/), on a throwaway
PostgreSQL database; the wall time and queries of one building_sweep (building/services.py)
with every device at rest, then while R1 holds ELEV-A and the car is called to R1's floor and
sent to another (the samples of "a ride" include the seconds after it has arrived).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import saving
from bench.stack import database_option, temporary_database

ROOT = Path(__file__).resolve().parent.parent
SITE_FILE = ROOT / "sites" / "eulji.yaml"


@saving.saves("building_sweep")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 sweeps each: for CI")
    database_option(parser)
    saving.add_argument(parser)
    options = parser.parse_args()
    sweeps = 20 if options.quick else 200
    with temporary_database(options.database) as url:
        rows = measure(url, sweeps=sweeps)
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"building sweep benchmark, {today} (UTC), Python {platform.python_version()}")
    print(
        f"{'devices':>7}  {'state':<8} {'sweeps':>6} {'median ms':>9} {'p90 ms':>7} {'queries':>7}"
    )
    for devices, state, samples, queries in rows:
        p90 = statistics.quantiles(samples, n=10)[-1] if len(samples) > 1 else samples[0]
        median = statistics.median(samples)
        print(f"{devices:>7}  {state:<8} {len(samples):>6} {median:>9.2f} {p90:>7.2f} {queries:>7}")


def measure(database_url: str, *, sweeps: int) -> list[tuple]:
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        LOG_LEVEL="WARNING",
        BUILDING_ADAPTER="sim",
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()
    from django.db import connection
    from django.test.utils import CaptureQueriesContext
    from django.utils import timezone

    from building.models import Device
    from building.services import building_sweep, devices_ensure
    from robots.models import Floor, Resource, Robot
    from robots.sitefile import site_file_read, site_load
    from tests.factories import lease_acquire

    site = site_load(data=site_file_read(SITE_FILE))
    devices_ensure(site=site)
    devices = Device.objects.count()
    clock = timezone.now()

    def run(label: str) -> tuple:
        nonlocal clock
        samples, queries = [], 0
        for _ in range(sweeps):
            clock += datetime.timedelta(seconds=1)
            with CaptureQueriesContext(connection) as captured:
                started = time.perf_counter()
                building_sweep(now=clock)
                samples.append((time.perf_counter() - started) * 1000)
            queries = max(queries, len(captured))
        return devices, label, samples, queries

    run("warm-up")  # the first sweeps fill the statement and site caches: not measured
    at_rest = run("at rest")
    robot = Robot.objects.get(code="R1")
    lowest = Floor.objects.filter(site=site).order_by("level").last()
    Robot.objects.filter(pk=robot.pk).update(floor=lowest)
    robot.refresh_from_db()
    elevator = Resource.objects.get(site=site, code="ELEV-A")
    floors = list(Floor.objects.filter(site=site).order_by("level").values_list("code", flat=True))
    lease_acquire(
        robot=robot, resource=elevator, request_id="bench-1", to_floor=floors[0], now=clock
    )
    riding = run("a ride")  # called to its floor, then to the lowest: moving, then at rest
    return [at_rest, riding]


if __name__ == "__main__":
    main()
