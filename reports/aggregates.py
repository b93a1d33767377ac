"""SQL the reports need that Django does not ship: seconds between two timestamps, on
PostgreSQL and on SQLite (the embedded default)."""

from django.db.models import FloatField, Func


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
