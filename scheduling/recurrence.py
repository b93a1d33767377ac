"""When a periodic request occurs: pure functions of its `repeat` and the site's time zone.

`repeat` is {"times": ["08:00", "14:00"]} (every day at those times) or
{"every_minutes": 120, "from": "08:00", "until": "20:00"} (both ends included).
"""

from collections.abc import Iterator
from datetime import date, datetime, time, timedelta
from zoneinfo import ZoneInfo

from django.conf import settings

MINUTES_PER_DAY = 24 * 60


def parse_clock(text: str) -> time:
    """'08:00' -> time(8, 0); ValueError unless it is HH:MM on a 24-hour clock."""
    hours, sep, minutes = text.partition(":")
    if not (sep and len(hours) == 2 and len(minutes) == 2 and (hours + minutes).isdigit()):
        raise ValueError(f"{text!r} is not HH:MM")
    return time(int(hours), int(minutes))


def day_times(repeat: dict) -> list[time]:
    """The local times of day at which `repeat` occurs, in order."""
    if "times" in repeat:
        return sorted({parse_clock(text) for text in repeat["times"]})
    first = _minute_of_day(parse_clock(repeat["from"]))
    last = _minute_of_day(parse_clock(repeat["until"]))
    minutes = range(first, last + 1, repeat["every_minutes"])
    return [time(minute // 60, minute % 60) for minute in minutes]


def occurrences(repeat: dict, start: datetime, end: datetime) -> Iterator[datetime]:
    """Every occurrence in [start, end], oldest first, as aware datetimes."""
    zone = ZoneInfo(settings.TIME_ZONE)
    times = day_times(repeat)
    for day in _days(start.astimezone(zone).date(), end.astimezone(zone).date()):
        for clock in times:
            at = datetime.combine(day, clock, tzinfo=zone)
            if start <= at <= end:
                yield at


def next_occurrence(repeat: dict, after: datetime) -> datetime:
    """The first occurrence at or after `after` (one is always within two days)."""
    return next(occurrences(repeat, after, after + timedelta(days=2)))


def _minute_of_day(clock: time) -> int:
    return clock.hour * 60 + clock.minute


def _days(first: date, last: date) -> Iterator[date]:
    day = first - timedelta(days=1)
    while day <= last:
        yield day
        day += timedelta(days=1)
