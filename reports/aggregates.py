"""SQL the reports need that Django does not ship: seconds between two timestamps and
percentiles, computed by the database (PostgreSQL: PERCENTILE_CONT; SQLite has none, so
reports/selectors.py computes those in Python there)."""

from django.db import connection
from django.db.models import Aggregate, FloatField, Func


class Seconds(Func):
    """`end - start` in seconds (NULL if either is)."""

    output_field = FloatField()

    def __init__(self, end, start):
        super().__init__(end, start)

    def as_postgresql(self, compiler, connection, **extra):
        template = "EXTRACT(EPOCH FROM (%(expressions)s))"
        return self.as_sql(compiler, connection, template=template, arg_joiner=" - ", **extra)

    def as_sqlite(self, compiler, connection, **extra):
        template = "((julianday(%(expressions)s)) * 86400.0)"
        joiner = ") - julianday("
        return self.as_sql(compiler, connection, template=template, arg_joiner=joiner, **extra)


class Percentile(Aggregate):
    """PostgreSQL's continuous percentile of an expression, e.g. Percentile(x, 0.9)."""

    function = "PERCENTILE_CONT"
    name = "Percentile"
    output_field = FloatField()
    template = "%(function)s(%(fraction)s) WITHIN GROUP (ORDER BY %(expressions)s)"

    def __init__(self, expression, fraction: float, **extra):
        if not 0 <= fraction <= 1:
            raise ValueError(f"fraction {fraction} is not within 0..1")
        super().__init__(expression, fraction=repr(float(fraction)), **extra)


def database_percentiles() -> bool:
    return connection.vendor == "postgresql"


def percentile(values: list[float], fraction: float) -> float | None:
    """PERCENTILE_CONT in Python (linear interpolation), for databases without it."""
    ordered = sorted(v for v in values if v is not None)
    if not ordered:
        return None
    position = (len(ordered) - 1) * fraction
    low = int(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)
