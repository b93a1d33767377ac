"""Run by tests/reports/test_sqlite.py in a subprocess whose DATABASE_URL is a migrated SQLite
file (the embedded default): seeds a history on the tiny site, then prints as JSON every
table's rows computed live, the same rows read from the daily roll-ups, and the percentiles
Python computes from the raw rows (durations rounded to the histograms' buckets)."""

import json
import os
import sys
from datetime import date, datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")

import django  # noqa: E402

django.setup()

from django.conf import settings  # noqa: E402
from django.db import connection  # noqa: E402

from reports.rollups import rollup_sweep  # noqa: E402
from reports.seed import history_seed  # noqa: E402
from reports.selectors import Period  # noqa: E402
from reports.tables import TABLES  # noqa: E402
from resources.models import Lease  # noqa: E402
from scheduling.models import Task  # noqa: E402
from tests import factories  # noqa: E402

ZONE = ZoneInfo(settings.TIME_ZONE)
END = datetime(2026, 11, 20, tzinfo=ZONE)
NOW = END + timedelta(days=1)


def exact_percentile(values, fraction):
    ordered = sorted(values)
    position = (len(ordered) - 1) * fraction
    low = int(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def main():
    site = factories.site_create()
    for code in ("R1", "R2"):
        factories.robot_create(site, code)
    history_seed(site=site, deliveries=400, days=10, end=END, seed=5)
    period = Period(site=site, first=date(2026, 11, 12), last=date(2026, 11, 19))
    live = {table.key: table.compute(period, now=NOW) for table in TABLES}
    while rollup_sweep(now=NOW):
        pass
    rolled = {table.key: table.compute(period, now=NOW) for table in TABLES}
    tasks = Task.objects.filter(
        site=site, requested_time__gte=period.start, requested_time__lt=period.end
    )
    dropoffs = {}
    for task in tasks.exclude(delivered_at=None):
        seconds = round((task.delivered_at - task.requested_time).total_seconds())
        dropoffs.setdefault(task.priority, []).append(seconds)
    waits = {}
    leases = Lease.objects.filter(
        resource__site=site, requested_at__gte=period.start, requested_at__lt=period.end
    ).exclude(granted_at=None)
    for lease in leases.select_related("resource"):
        tenths = round((lease.granted_at - lease.requested_at).total_seconds() * 10)
        waits.setdefault(lease.resource.code, []).append(tenths / 10)
    expected = {
        "dropoff": {
            p: [exact_percentile(v, f) / 60 for f in (0.5, 0.9)] for p, v in dropoffs.items()
        },
        "wait": {code: [exact_percentile(v, f) for f in (0.5, 0.9)] for code, v in waits.items()},
    }
    print(
        json.dumps(
            {"vendor": connection.vendor, "live": live, "rolled": rolled, "expected": expected}
        )
    )


if __name__ == "__main__":
    main()
