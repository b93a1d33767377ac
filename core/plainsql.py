"""Plain SQL for the few statements every heartbeat or every allocation runs, written once from
the models' fields.

Django compiles a queryset's SQL again on every call (every column named and quoted, the
joins, the lock clause) and the text comes out the same each time: for a statement that runs
on every heartbeat of every robot, that compiling is most of its cost in the web process
(bench/heartbeat_cpu.py); for the allocation's wide reads of robots and routes, a millisecond
or more each in a nurse's request (bench/request_cpu.py --allocating). The statements are
built from the models' public `_meta` API (field columns, Field.get_db_prep_save,
Field.from_db_value, Model.from_db), so they follow the models, and each text is built once:
the database prepares it once per connection too (settings.DATABASE_PREPARED_STATEMENTS). Each
has a test that checks it against the ORM's own (tests/core/test_plainsql.py and the tests of
the modules using it).
"""

from functools import cache

from django.db import connection
from django.db.models import Model


def columns(model: type[Model], alias: str) -> str:
    """The model's concrete columns, `alias."column", ...`, in the order `loaded` takes them."""
    quote = connection.ops.quote_name
    return ", ".join(f"{alias}.{quote(field.column)}" for field in model._meta.concrete_fields)


def column(model: type[Model], field: str, alias: str = "") -> str:
    """The column of the model's field `field` (its primary key for "pk"), quoted: `"column"`,
    or `alias."column"`."""
    name = model._meta.pk.column if field == "pk" else model._meta.get_field(field).column
    quoted = connection.ops.quote_name(name)
    return f"{alias}.{quoted}" if alias else quoted


def table(model: type[Model]) -> str:
    """The model's table, quoted."""
    return connection.ops.quote_name(model._meta.db_table)


def loaded(model: type[Model], values) -> Model:
    """An instance of `model` from its concrete fields' column values, as the ORM loads one."""
    fields = model._meta.concrete_fields
    converted = [
        field.from_db_value(value, None, connection) if hasattr(field, "from_db_value") else value
        for field, value in zip(fields, values, strict=True)
    ]
    return model.from_db(connection.alias, [field.attname for field in fields], converted)


def row_update(instance: Model, field_names: tuple[str, ...]) -> None:
    """Write the named fields of a saved instance to its row, as
    `instance.save(update_fields=field_names)` does for fields without `auto_now` (no signals
    are sent: no receiver of ours listens to these models' saves)."""
    model = type(instance)
    fields = [model._meta.get_field(name) for name in field_names]
    values = [
        field.get_db_prep_save(getattr(instance, field.attname), connection) for field in fields
    ]
    with connection.cursor() as cursor:
        cursor.execute(_update_sql(model, field_names), [*values, instance.pk])


@cache
def _update_sql(model: type[Model], field_names: tuple[str, ...]) -> str:
    quote = connection.ops.quote_name
    assignments = ", ".join(
        f"{quote(model._meta.get_field(name).column)} = %s" for name in field_names
    )
    table, pk = quote(model._meta.db_table), quote(model._meta.pk.column)
    return f"UPDATE {table} SET {assignments} WHERE {pk} = %s"
