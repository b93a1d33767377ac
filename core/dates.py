"""Dates a client names in a query are bounded, so what is computed from them (a day added, a
time zone applied, a range of days) stays inside what Python's dates and the databases hold:
a far-future date is refused naming its parameter, never a 500."""

from datetime import date, timedelta

from django.utils.translation import gettext

EARLIEST = date(2000, 1, 1)
AHEAD = timedelta(days=366)


def date_out_of_range(value: date, *, today: date) -> str | None:
    """Why `value` is refused ("" never), or None when it lies in the range."""
    latest = today + AHEAD
    if EARLIEST <= value <= latest:
        return None
    said = gettext("must be between %(earliest)s and %(latest)s")
    return said % {"earliest": EARLIEST.isoformat(), "latest": latest.isoformat()}
