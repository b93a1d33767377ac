"""Commits that need not wait for the disk: a transaction that wrote only what its next
occurrence writes again (a robot's reported state and presence) may be lost in a crash
without losing anything, so it commits without waiting for its WAL flush.

PostgreSQL's `synchronous_commit = off`, set for one transaction (SET LOCAL): the commit returns
before the write-ahead log reaches the disk (the WAL writer flushes it within
wal_writer_delay, 200 ms by default). A crash of the database server in that window loses the
transaction; it can never corrupt or half-apply it, and other transactions' commits keep their
durability. One WAL flush can take longer than the heartbeat's own work (pg_test_fsync shows
it), and nearly every heartbeat writes only its robot's row.

Everything else still waits: a transaction that wrote to any other table (a board message, an
event, an ack, a task given back) commits as usual.
"""

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from django.db import connection

_WRITES = ("INSERT", "UPDATE", "DELETE")


@dataclass
class _Writes:
    tables: frozenset[str]
    other: bool = False

    def __call__(self, execute, sql, params, many, context):
        if not self.other and sql.lstrip()[:6].upper() in _WRITES and not self._only_ours(sql):
            self.other = True
        return execute(sql, params, many, context)

    def _only_ours(self, sql: str) -> bool:
        # Django writes `UPDATE "t" SET`, `INSERT INTO "t" (`, `DELETE FROM "t" WHERE`.
        words = sql.split(None, 3)
        table = words[2] if words[0].upper() in ("INSERT", "DELETE") else words[1]
        return table.strip('"') in self.tables


@contextmanager
def relaxed_commit_unless_written(*, tables: frozenset[str]) -> Iterator[None]:
    """Last in a transaction (PostgreSQL): if nothing was written in the block but rows of
    `tables`, the transaction's commit does not wait for the disk. A no-op on other
    databases, and when the block set the transaction to roll back.

    When the block is the last thing in the outermost atomic block, it commits at its end
    itself, `SET LOCAL` and `COMMIT` sent in one round trip instead of two (the atomic block's
    own commit then finds nothing to do): one round trip of six fewer for a plain heartbeat,
    each a wait on PostgreSQL that holds a sync worker. Nested in another transaction (a test's),
    it only sets the commit's mode, for whichever commit comes.
    """
    if connection.vendor != "postgresql":
        yield
        return
    writes = _Writes(tables)
    with connection.execute_wrapper(writes):
        yield
    if writes.other or connection.needs_rollback:
        return
    with connection.cursor() as cursor:
        cursor.execute(_RELAXED_COMMIT if _outermost() else _RELAXED)


_RELAXED = "SET LOCAL synchronous_commit TO OFF"
# Two statements with no parameters: psycopg sends them as one simple query, never prepared.
_RELAXED_COMMIT = f"{_RELAXED}; COMMIT"


def _outermost() -> bool:
    """In the outermost atomic block: a COMMIT now ends the very transaction that block would
    commit (one of a test's, which rolls back, would not)."""
    return len(connection.atomic_blocks) == 1
