"""Statements of the hot paths (the heartbeat's; the webhook subscriptions every task status
change looks up; a delivery request's token, site, and the stops and history of its answer;
an allocation's lock, available robots, their routes' stops and the chosen robot's last plan;
an allocation batch's claim of each task and its tasks' ETAs), compiled once per process
instead of once per call.

Django builds a queryset's SQL again every time it is evaluated: the lookups are resolved, the
joins set up, every column named and quoted. For the statements a heartbeat always runs (find
the robot by its token and lock its row; store the state it reports; read its board) that was
about a third of the heartbeat's CPU (bench/heartbeat_cpu.py; README "Serving"), spent producing
the same text with other values. Here a statement is built once by the ORM with stand-in values,
compiled once per database vendor, and then run with each call's values put where the
stand-ins were; its rows become model instances the way Django's own iterable makes them
(from_db, the select_related populators, the fields' converters). So the statement stays
written with the ORM, where the models define it, and a wrong stand-in fails at the first call,
not silently.

On PostgreSQL the statements are also prepared, once per connection: the server parses and
plans each once and then only binds the values (settings.DATABASE_PREPARED_STATEMENTS; Django's
own queries bind on the client and are parsed and planned every time). Every execution goes
through Django's cursor wrapper all the same: execute wrappers (core/commits.py), query logging
and the test suite's query counts see them as any other query.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from itertools import count

from django.conf import settings
from django.db import DEFAULT_DB_ALIAS, DatabaseError, connection, connections
from django.db.models import Model, QuerySet, signals
from django.db.models.query import get_related_populators

_stand_ins = count(7_300_000_000_000_001)


@dataclass(frozen=True)
class _Compiled:
    sql: str
    params: tuple
    slots: dict[str, tuple[int, ...]]  # value name -> its positions among the params
    compiler: object
    converters: dict
    init_list: list[str]
    fields_start: int
    fields_end: int
    related_populators: list

    def bind(self, values: dict) -> list:
        params = list(self.params)
        for name, positions in self.slots.items():
            for position in positions:
                params[position] = values[name]
        return params

    def instances(self, rows: list[tuple]) -> list[Model]:
        if self.converters:
            rows = self.compiler.apply_converters(rows, self.converters)
        model = self.compiler.klass_info["model"]
        db = DEFAULT_DB_ALIAS
        objects = []
        for row in rows:
            obj = model.from_db(db, self.init_list, row[self.fields_start : self.fields_end])
            for populator in self.related_populators:
                populator.populate(row, obj)
            objects.append(obj)
        return objects


class Statement:
    """A queryset built by `build` from named values (their types in `kinds`: str, int or float),
    compiled once per database vendor, then run with other values.

        robot_by_token = Statement(lambda token_hash: Robot.objects.filter(...), token_hash=str)
        robot_by_token.first(token_hash=...)

    Only plain model querysets (select_related allowed; no annotations, values() or
    prefetches): what ModelIterable makes of them is rebuilt here without those cases.
    """

    def __init__(self, build: Callable[..., QuerySet], **kinds: type):
        self._build, self._kinds = build, kinds
        self._compiled: dict[str, _Compiled] = {}

    def all(self, **values) -> list[Model]:
        db = _db()
        compiled = self._compiled.get(db.vendor) or self._compile()
        with _cursor(db) as cursor:
            cursor.execute(compiled.sql, compiled.bind(values))
            rows = cursor.fetchall()
        return compiled.instances(rows)

    def first(self, **values) -> Model | None:
        found = self.all(**values)
        return found[0] if found else None

    def _compile(self) -> _Compiled:
        stand_ins = {name: _stand_in(name, kind) for name, kind in self._kinds.items()}
        queryset = self._build(**stand_ins)
        if queryset.query.annotations or queryset._fields or queryset._prefetch_related_lookups:
            raise TypeError("Statement takes plain model querysets only")
        compiler = queryset.query.get_compiler(connection=connection)
        sql, params = compiler.as_sql()  # also sets compiler.select and klass_info
        slots = {
            name: tuple(n for n, param in enumerate(params) if param == stand_in)
            for name, stand_in in stand_ins.items()
        }
        missing = [name for name, positions in slots.items() if not positions]
        if missing:
            raise TypeError(f"the statement's SQL does not carry {missing} as parameters")
        select, klass_info = compiler.select, compiler.klass_info
        start, end = klass_info["select_fields"][0], klass_info["select_fields"][-1] + 1
        compiled = _Compiled(
            sql=sql,
            params=tuple(params),
            slots=slots,
            compiler=compiler,
            converters=compiler.get_converters([s[0] for s in select[: compiler.col_count]]),
            init_list=[column[0].target.attname for column in select[start:end]],
            fields_start=start,
            fields_end=end,
            related_populators=get_related_populators(klass_info, select, connection.alias),
        )
        self._compiled[connection.vendor] = compiled
        return compiled


def _stand_in(name: str, kind: type):
    if kind is int:
        return next(_stand_ins)
    if kind is float:  # unequal to every other stand-in: they share the counter
        return float(next(_stand_ins))
    if kind is str:
        return f"\x1fstand-in {name} {next(_stand_ins)}\x1f"
    raise TypeError(f"{name}: stand-ins are str, int or float, not {kind}")


_updates: dict[tuple, tuple[str, list]] = {}


def row_update(instance: Model, fields: Sequence[str]) -> None:
    """instance.save(update_fields=fields), with the UPDATE compiled once per model, fields and
    vendor. Falls back to save() where that does more than write the values: a model with
    pre_save or post_save receivers, or a value that is an expression."""
    model = type(instance)
    if signals.pre_save.has_listeners(model) or signals.post_save.has_listeners(model):
        instance.save(update_fields=fields)
        return
    db = _db()
    sql, concrete = _updates.get((model, tuple(fields), db.vendor)) or _update_compile(
        model, fields
    )
    values = [field.pre_save(instance, False) for field in concrete]
    if any(hasattr(value, "resolve_expression") for value in values):
        instance.save(update_fields=fields)
        return
    prepared = zip(concrete, values, strict=True)
    params = [field.get_db_prep_save(value, db) for field, value in prepared]
    with _cursor(db) as cursor:
        cursor.execute(sql, [*params, instance.pk])
        if cursor.rowcount == 0:  # as save() says it
            raise DatabaseError("Save with update_fields did not affect any rows.")


def _update_compile(model: type[Model], fields: Sequence[str]) -> tuple[str, list]:
    meta, quote = model._meta, connection.ops.quote_name
    concrete = _written_fields(model, fields, "row_update")
    assignments = ", ".join(f"{quote(field.column)} = %s" for field in concrete)
    sql = f"UPDATE {quote(meta.db_table)} SET {assignments} WHERE {quote(meta.pk.column)} = %s"
    _updates[(model, tuple(fields), connection.vendor)] = (sql, concrete)
    return sql, concrete


def _written_fields(model: type[Model], fields: Sequence[str], writer: str) -> list:
    """The model's fields by name; TypeError unless each is a concrete non-key field."""
    concrete = [model._meta.get_field(name) for name in fields]
    if any(not field.concrete or field.primary_key for field in concrete):
        raise TypeError(f"{writer} writes concrete non-key fields only, not {fields}")
    return concrete


_claims: dict[tuple, tuple[str, list, list]] = {}


def row_claim(instance: Model, fields: Sequence[str], **expected) -> bool:
    """Write the instance's `fields` only if its row still holds the `expected` values (None:
    NULL), as filter(pk=..., **expected).update(...) would, signals aside; whether it did.
    Compiled once per model, fields, expected names and vendor: an allocation batch claims
    every task it assigns this way."""
    model = type(instance)
    nulls = tuple((name, value is None) for name, value in expected.items())
    db = _db()
    key = (model, tuple(fields), nulls, db.vendor)
    sql, concrete, checked = _claims.get(key) or _claim_compile(key)
    params = [field.get_db_prep_save(field.pre_save(instance, False), db) for field in concrete]
    params.append(instance.pk)
    params += [field.get_db_prep_value(expected[field.name], db) for field in checked]
    with _cursor(db) as cursor:
        cursor.execute(sql, params)
        return cursor.rowcount == 1


def _claim_compile(key: tuple) -> tuple[str, list, list]:
    model, fields, nulls, _vendor = key
    sql, concrete = _update_compile(model, fields)
    quote, meta = connection.ops.quote_name, model._meta
    checked = [meta.get_field(name) for name, null in nulls if not null]
    conditions = [f"{quote(field.column)} = %s" for field in checked]
    conditions += [f"{quote(meta.get_field(name).column)} IS NULL" for name, null in nulls if null]
    _claims[key] = (" AND ".join([sql, *conditions]), concrete, checked)
    return _claims[key]


def rows_update(objects: Sequence[Model], fields: Sequence[str]) -> None:
    """bulk_update(objects, fields) of one model's objects, in one statement whatever their
    number. On PostgreSQL the values go as one array per column (UPDATE ... FROM unnest), so
    the statement is the same text for any count and its SQL is built once; elsewhere it is
    Django's bulk_update (CASE WHEN per object, built each time)."""
    if not objects:
        return
    model, db = type(objects[0]), _db()
    if db.vendor != "postgresql":
        model._base_manager.bulk_update(objects, fields)
        return
    sql, concrete = _arrays_updates.get((model, tuple(fields))) or _arrays_compile(model, fields)
    columns = [[obj.pk for obj in objects]]
    for field in concrete:
        columns.append([field.get_db_prep_save(getattr(obj, field.attname), db) for obj in objects])
    with _cursor(db) as cursor:
        cursor.execute(sql, columns)


_arrays_updates: dict[tuple, tuple[str, list]] = {}


def _arrays_compile(model: type[Model], fields: Sequence[str]) -> tuple[str, list]:
    meta, quote = model._meta, connection.ops.quote_name
    concrete = _written_fields(model, fields, "rows_update")
    every = [meta.pk, *concrete]
    arrays = ", ".join(
        f"%s::{field.rel_db_type(connection) if field.primary_key else field.db_type(connection)}[]"
        for field in every
    )
    names = ", ".join(f"c{n}" for n in range(len(every)))
    assignments = ", ".join(
        f"{quote(field.column)} = v.c{n}" for n, field in enumerate(concrete, 1)
    )
    table, pk = quote(meta.db_table), quote(meta.pk.column)
    sql = (
        f"UPDATE {table} SET {assignments} FROM unnest({arrays}) AS v({names}) "
        f"WHERE {table}.{pk} = v.c0"
    )
    _arrays_updates[(model, tuple(fields))] = (sql, concrete)
    return sql, concrete


def rows_insert(objects: Sequence[Model]) -> list[Model]:
    """bulk_create(objects) of one model's new objects (no primary key yet), in one statement
    whatever their number; returns them with their keys. On PostgreSQL the statement is built
    once per model and number of rows (Django builds its INSERT again on every call, and a
    nurse's request or a delivery's report inserts several times), prepared like the other
    statements: up to VALUES_ROWS rows, one VALUES row each, as create() writes one; more, one
    array per column, as Django's own bulk_create sends them there (INSERT ... SELECT * FROM
    UNNEST(...)). Elsewhere, or where that would not write what bulk_create writes (an
    expression for a value, a column UNNEST cannot carry), it is bulk_create."""
    if not objects:
        return []
    model, db = type(objects[0]), _db()
    compiled = db.vendor == "postgresql" and (
        _inserts[model] if model in _inserts else _insert_compile(model)
    )
    if not compiled or any(obj.pk is not None for obj in objects):
        return model._base_manager.bulk_create(objects)
    concrete = compiled.concrete
    for obj in objects:
        obj._prepare_related_fields_for_save(operation_name="bulk_create")
    rows = [[field.pre_save(obj, True) for field in concrete] for obj in objects]
    if any(hasattr(value, "resolve_expression") for row in rows for value in row):
        return model._base_manager.bulk_create(objects)
    if len(rows) <= VALUES_ROWS:  # a row's values as scalars: arrays cost psycopg far more
        sql = compiled.values(len(rows))
        params = [
            field.get_db_prep_save(value, db)
            for row in rows
            for field, value in zip(concrete, row, strict=True)
        ]
    else:
        sql = compiled.unnest
        params = [
            [field.get_db_prep_save(row[n], db) for row in rows] for n, field in enumerate(concrete)
        ]
    with _cursor(db) as cursor:
        cursor.execute(sql, params)
        keys = cursor.fetchall()
    for obj, (key,) in zip(objects, keys, strict=True):
        obj.pk = key
        obj._state.adding, obj._state.db = False, DEFAULT_DB_ALIAS
    return list(objects)


def row_insert(instance: Model) -> Model:
    """Model.objects.create(...) of a built instance: on PostgreSQL with rows_insert's
    statement, elsewhere and where that does more than write the row (pre_save or post_save
    receivers) with save(), as create() does."""
    model = type(instance)
    if (
        _db().vendor != "postgresql"
        or signals.pre_save.has_listeners(model)
        or signals.post_save.has_listeners(model)
    ):
        instance.save(force_insert=True)
        return instance
    return rows_insert([instance])[0]


VALUES_ROWS = 8  # rows_insert sends at most this many rows as VALUES rows, more as arrays


class _Insert:
    """A model's INSERT of every concrete column but an automatic key, returning the key: its
    values as VALUES rows (the statement built once per number of rows) or as arrays."""

    def __init__(self, concrete: list, table: str, key: str, columns: str, arrays: str):
        self.concrete = concrete
        self.head, self.returning = f"INSERT INTO {table} ({columns})", f"RETURNING {key}"
        self.row = f"({', '.join(['%s'] * len(concrete))})"
        self.unnest = f"{self.head} SELECT * FROM UNNEST({arrays}) {self.returning}"
        self.by_count: dict[int, str] = {}

    def values(self, count: int) -> str:
        if count not in self.by_count:
            rows = ", ".join([self.row] * count)
            self.by_count[count] = f"{self.head} VALUES {rows} {self.returning}"
        return self.by_count[count]


_inserts: dict[type[Model], _Insert | None] = {}


def _insert_compile(model: type[Model]) -> _Insert | None:
    """The model's _Insert; None where bulk_create would not use UNNEST for its columns (its
    own test, Django 5.2's postgresql SQLInsertCompiler.assemble_as_sql) or the key is not set
    by the database."""
    meta, quote = model._meta, connection.ops.quote_name
    concrete = [field for field in meta.concrete_fields if not field.primary_key]
    internal = [(f.target_field if f.is_relation else f).get_internal_type() for f in concrete]
    if (
        not meta.pk.db_returning
        or any(field.generated or field.has_db_default() for field in concrete)
        or any(hasattr(field, "get_placeholder") for field in concrete)
        or any(kind not in connection.data_types for kind in internal)
    ):
        _inserts[model] = None
        return None
    table = quote(meta.db_table)
    _inserts[model] = _Insert(
        concrete,
        table,
        key=f"{table}.{quote(meta.pk.column)}",
        columns=", ".join(quote(field.column) for field in concrete),
        arrays=", ".join(f"({_array(field)})" for field in concrete),
    )
    return _inserts[model]


def _array(field) -> str:
    """A parameter holding an array of the field's values, cast to its column's type without
    the type's parameters, as Django's bulk insert writes it: varchar[], not varchar(50)[] (a
    cast to that would cut a longer value short instead of refusing it)."""
    return f"%s::{field.db_type(connection).split('(')[0]}[]"


def values_stored(model: type[Model], field: str, values: Sequence, **equal) -> set:
    """Which of `values` the model's rows hold in `field`, among the rows whose fields in
    `equal` hold those values: set(filter(**equal, <field>__in=values).values_list(field)).
    On PostgreSQL the statement is built once per model and fields, the values one array (= ANY),
    so its text is the same for any number of them; elsewhere it is that queryset."""
    if not values:
        return set()
    db = _db()
    if db.vendor != "postgresql":
        found = model._base_manager.filter(**equal, **{f"{field}__in": list(values)})
        return set(found.values_list(field, flat=True))
    names = tuple(equal)
    sql, among, equals = _values_stored.get((model, field, names)) or _values_compile(
        model, field, names
    )
    params = [f.get_db_prep_value(equal[name], db) for name, f in zip(names, equals, strict=True)]
    params.append([among.get_db_prep_value(value, db) for value in values])
    with _cursor(db) as cursor:
        cursor.execute(sql, params)
        return {row[0] for row in cursor.fetchall()}


_values_stored: dict[tuple, tuple[str, object, list]] = {}


def _values_compile(model: type[Model], field: str, names: tuple[str, ...]):
    meta, quote = model._meta, connection.ops.quote_name
    among, equals = meta.get_field(field), [meta.get_field(name) for name in names]
    conditions = [f"{quote(f.column)} = %s" for f in equals]
    conditions.append(f"{quote(among.column)} = ANY({_array(among)})")
    sql = (
        f"SELECT {quote(among.column)} FROM {quote(meta.db_table)} WHERE {' AND '.join(conditions)}"
    )
    _values_stored[(model, field, names)] = (sql, among, equals)
    return _values_stored[(model, field, names)]


def _cursor(db):
    """The connection's cursor (`db`, from _db()), or on PostgreSQL one that prepares every
    statement it runs.

    Not while queries are logged (DEBUG, the tests' query captures): the log shows a query's
    SQL with its values as the client-binding cursor builds it, which a server-binding cursor
    does not keep; the statements and their results are the same either way."""
    prepared = settings.DATABASE_PREPARED_STATEMENTS and db.vendor == "postgresql"
    if not prepared or db.queries_logged:
        return db.cursor()
    db.validate_thread_sharing()
    db.close_if_health_check_failed()
    db.ensure_connection()
    raw = db.connection
    if raw.prepare_threshold is None:  # Django's default: psycopg prepares nothing, even asked
        # Only cursors that ask prepare: Django's client-binding cursors never do.
        raw.prepare_threshold = _PREPARE_ONLY_WHEN_ASKED
    return db.make_cursor(_preparing_cursor_class()(raw))


def _db():
    """The default database's connection (of this thread), looked up once where it is used
    several times: each use of django.db.connection looks it up again."""
    return connections[DEFAULT_DB_ALIAS]


_PREPARE_ONLY_WHEN_ASKED = 2**31 - 1  # executions before psycopg would prepare by itself


@cache
def _preparing_cursor_class():
    # Imported on first use: the module imports psycopg, which SQLite-only runs need not have.
    from django.db.backends.postgresql.base import ServerBindingCursor

    class PreparingCursor(ServerBindingCursor):
        """Binds values on the server and prepares the statement (psycopg keeps it per
        connection, keyed by the SQL and the values' types)."""

        def execute(self, query, params=None, *, prepare=None, binary=None):
            return super().execute(query, params, prepare=True, binary=binary)

    return PreparingCursor
