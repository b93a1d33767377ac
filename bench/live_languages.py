"""What speaking every language costs the push path: the live payload of a robot's change and of
a task's change built once in the default language (what one language would cost), against
built in every language the pages speak with each other language's differing fields
(ui/live/publish.payload_in_each_language, what the server does), measured in-process in one
run, alternating.

    python bench/live_languages.py           # 7 rounds of 2,000 of each
    python bench/live_languages.py --quick   # 2 rounds of 200: what CI runs

The robot is one of the Eulji site's, at a station with a name in Korean and Italian (its
place and floor are translated as well as its labels); the task's change is its assignment.
Times are CPU-bound and per payload; the payload is built inside a heartbeat's or a service's
transaction, so this is what each change adds before the message leaves.
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


@saving.saves("live_languages")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 rounds of 200: for CI")
    database_option(parser)
    saving.add_argument(parser)
    options = parser.parse_args()
    rounds, per_round = (2, 200) if options.quick else (7, 2000)
    with temporary_database(options.database) as url:
        results, languages = measure(url, rounds=rounds, per_round=per_round)
    today = datetime.datetime.now(datetime.UTC).date()
    print(f"live payload languages benchmark, {today} (UTC), Python {platform.python_version()}")
    print(f"{rounds} rounds of {per_round} of each; languages: {', '.join(languages)}")
    print("| payload | µs, one language | µs, every language | ratio | fields translated |")
    print("|---|---|---|---|---|")
    for name, (one, every, fields) in results.items():
        print(f"| {name} | {one:.1f} | {every:.1f} | {every / one:.2f} | {fields} |")


def measure(database_url: str, *, rounds: int, per_round: int):
    os.environ.update(
        DATABASE_URL=database_url,
        DJANGO_SETTINGS_MODULE="hospital_delivery.settings",
        LOG_LEVEL="WARNING",
    )
    os.environ.setdefault("SECRET_KEY", "bench-only-secret")
    import django

    django.setup()
    from django.conf import settings
    from django.utils import translation

    from robots.models import Robot
    from robots.sitefile import site_file_read, site_load
    from scheduling.choices import Cause, TaskStatus
    from scheduling.models import Task, TaskTransition
    from ui.live.payloads import robot_payload, task_payload
    from ui.live.publish import payload_in_each_language

    site = site_load(data=site_file_read(Path(settings.BASE_DIR) / "sites" / "eulji.yaml"))
    station = site.waypoints.get(code="2F-LAB-DROP")
    robot = Robot.objects.create(
        site=site, code="B1", dock=site.waypoints.filter(kind="dock").first(), capacity=4
    )
    Robot.objects.filter(pk=robot.pk).update(
        floor_id=station.floor_id, waypoint_id=station.pk, status="moving"
    )
    robot = Robot.objects.select_related("site").get(pk=robot.pk)
    task = Task(pk=1, site=site, contents="Blood sample", status=TaskStatus.ASSIGNED)
    entry = TaskTransition(
        task=task, at=robot.site.loaded_at, old="due", new="assigned", cause=Cause.ALLOCATION
    )
    builds = {
        "robot (fleet table, floor map)": lambda: robot_payload(robot),
        "task (schedule, station page)": lambda: task_payload(entry),
    }
    results = {}
    for name, build in builds.items():
        results[name] = _compare(
            build,
            payload_in_each_language,
            translation,
            settings,
            rounds=rounds,
            per_round=per_round,
        )
    return results, [code for code, _name in settings.LANGUAGES]


def _compare(build, in_each_language, translation, settings, *, rounds: int, per_round: int):
    def one_language() -> None:
        with translation.override(settings.LANGUAGE_CODE):
            build()

    def every_language() -> None:
        in_each_language(build)

    def per_payload(call) -> float:
        started = time.perf_counter()
        for _ in range(per_round):
            call()
        return (time.perf_counter() - started) / per_round * 1e6

    for call in (one_language, every_language):
        per_payload(call)  # warm: catalogs loaded, the site map cached
    one, every = [], []
    for _ in range(rounds):
        one.append(per_payload(one_language))
        every.append(per_payload(every_language))
    _data, translated = in_each_language(build)
    fields = sum(len(changed) for changed in translated.values())
    return statistics.median(one), statistics.median(every), fields


if __name__ == "__main__":
    main()
