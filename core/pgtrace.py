"""What a connection sends PostgreSQL, one entry a round trip, read from libpq's own trace.

Django's query log (CaptureQueriesContext) counts statements, not waits on the server: it lists
Django's BEGIN and COMMIT even when psycopg sends nothing for them (a commit with no
transaction open), and a statement of two commands as one. libpq's trace (PQtrace) records
the messages themselves: a simple query (its text) or a Sync, which ends a prepared statement's
run. For tests and benchmarks (bench/heartbeat_instructions.py); PostgreSQL only.
"""

import tempfile
from collections.abc import Iterator
from contextlib import contextmanager

from django.db import connection

PREPARED = "prepared"  # the entry for a prepared statement's run (Bind, Execute, Sync)


@contextmanager
def round_trips() -> Iterator[list[str]]:
    """The round trips the default connection makes in the block, filled in at its end: each
    a simple query's text, or PREPARED. The connection must be open."""
    sent: list[str] = []
    raw = connection.connection.pgconn
    with tempfile.TemporaryFile("w+") as trace:
        raw.trace(trace.fileno())
        try:
            yield sent
        finally:
            raw.untrace()  # flushes the trace
        trace.seek(0)
        for line in trace:
            # "time, direction (F: sent, B: received), length, message, what it carries"
            _, direction, _, message, *carried = line.rstrip("\n").split("\t")
            if direction == "F" and message == "Query":
                sent.append(carried[0].strip().strip('"'))
            elif direction == "F" and message == "Sync":
                sent.append(PREPARED)
