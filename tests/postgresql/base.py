"""PostgreSQL for the tests (tests/settings.py): Django's own backend, subclassed as Django's
documentation describes, with one change: how a transactional test empties the database.

After every transactional test (every `live_server` test), Django empties every table with
`flush`: on PostgreSQL one TRUNCATE of them all, which gives each table and index new files, then
post_migrate makes the content types and permissions again. A test leaves a few rows, and
deleting them takes a small fraction of the TRUNCATE's time (tests/test_postgresql_flush.py
checks that the same tables end empty). The content types and permissions are kept: no test
writes them, and post_migrate, finding them all, then adds none.
"""

from django.db import OperationalError
from django.db.backends.postgresql import base, operations
from psycopg import errors

KEPT = frozenset({"django_content_type", "auth_permission"})
FLUSH_ATTEMPTS = 3


class DatabaseOperations(operations.DatabaseOperations):
    def sql_flush(self, style, tables, *, reset_sequences=False, allow_cascade=False):
        if reset_sequences:  # a test that asked for its sequences to start again
            return super().sql_flush(
                style, tables, reset_sequences=True, allow_cascade=allow_cascade
            )
        emptied = [self.quote_name(table) for table in tables if table not in KEPT]
        if not emptied:
            return []
        # Locked first, as TRUNCATE locks them: the flush waits for the transactions of threads
        # a test left running, and no write of theirs lands between two of the DELETEs. The
        # foreign keys Django makes are checked at commit (DEFERRABLE INITIALLY DEFERRED), and
        # flush runs these in one transaction: the order of the tables does not matter.
        lock = f"LOCK TABLE {', '.join(emptied)} IN ACCESS EXCLUSIVE MODE"
        return [lock, *(f"DELETE FROM {table}" for table in emptied)]

    def execute_sql_flush(self, sql_list):
        # A thread a test left running may hold one of the tables while it waits for another
        # the flush has locked (TRUNCATE would meet it too). PostgreSQL ends one of the two;
        # when that is the flush, the thread's transaction then finishes and the flush, whose
        # transaction was rolled back whole, starts again.
        for _ in range(FLUSH_ATTEMPTS - 1):
            try:
                return super().execute_sql_flush(sql_list)
            except OperationalError as error:
                if not isinstance(error.__cause__, errors.DeadlockDetected):
                    raise
        return super().execute_sql_flush(sql_list)


class DatabaseWrapper(base.DatabaseWrapper):
    ops_class = DatabaseOperations
