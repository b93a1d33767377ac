"""The tests' PostgreSQL backend (tests/postgresql/base.py) empties the database as Django's
flush does: every table but the content types and permissions, which stay as post_migrate
makes them."""

import contextlib
import threading
import time

import psycopg
import pytest
from django.contrib.auth.models import Permission
from django.contrib.contenttypes.models import ContentType
from django.core.management import call_command
from django.core.management.color import no_style
from django.db import connection

from boards.services import board_post
from tests.factories import robot_create, site_create, staff_create

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.mark.skipif(connection.vendor != "postgresql", reason="the PostgreSQL backend's flush")
def test_it_empties_every_table_but_the_content_types_and_permissions():
    assert type(connection.ops).__module__ == "tests.postgresql.base"
    robot = robot_create(site_create(), "R1")
    board_post(robot=robot, type="plan", body={"stops": []})
    staff_create()
    content_types = set(ContentType.objects.values_list("app_label", "model"))
    permissions = set(Permission.objects.values_list("content_type__model", "codename"))

    # Rows referring to one another, deleted in the tables' order: committed only because the
    # foreign keys are checked at the commit.
    call_command("flush", interactive=False, verbosity=0)

    assert _tables_with_rows() == {"django_content_type", "auth_permission"}
    assert set(ContentType.objects.values_list("app_label", "model")) == content_types
    assert set(Permission.objects.values_list("content_type__model", "codename")) == permissions


@pytest.mark.skipif(connection.vendor != "postgresql", reason="the PostgreSQL backend's flush")
def test_it_starts_again_when_a_transaction_left_running_deadlocks_with_it():
    site_create()
    tables = _flushed_tables()
    first, last = tables[0], tables[-1]
    failures = []
    with psycopg.connect(**_params()) as other:  # a thread's transaction a test left running
        other.execute(f"SELECT FROM {last} LIMIT 1")  # holds `last`
        flush = threading.Thread(target=_flush_into, args=(failures,))
        flush.start()  # locks `first`, then waits for `last`
        _wait_for_a_lock_wait(other)
        # `other` now waits for `first`: a deadlock, which PostgreSQL breaks by ending the
        # flush's transaction (the one that has waited longer finds it) or this one.
        with contextlib.suppress(psycopg.errors.DeadlockDetected):
            other.execute(f"SELECT FROM {first} LIMIT 1")
        other.rollback()
        flush.join(timeout=30)

    assert not flush.is_alive()
    assert failures == []
    assert _tables_with_rows() == {"django_content_type", "auth_permission"}


def _flushed_tables() -> list[str]:
    tables = connection.introspection.django_table_names(only_existing=True)
    lock = connection.ops.sql_flush(no_style(), tables)[0]
    return lock.removeprefix("LOCK TABLE ").removesuffix(" IN ACCESS EXCLUSIVE MODE").split(", ")


def _params() -> dict:
    params = connection.get_connection_params()
    return {
        key: value
        for key, value in params.items()
        if key in ("dbname", "user", "password", "host", "port")
    }


def _flush_into(failures: list) -> None:
    try:
        call_command("flush", interactive=False, verbosity=0)
    except Exception as failure:  # noqa: BLE001 - reported by the test's assertion
        failures.append(failure)


def _wait_for_a_lock_wait(other, timeout: float = 30.0) -> None:
    """Until another backend than `other`'s waits for a lock in this database (pg_locks, which
    unlike pg_stat_activity is read afresh inside a transaction)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        waiting = other.execute(
            "SELECT count(*) FROM pg_locks WHERE NOT granted AND pid <> pg_backend_pid() "
            "AND database = (SELECT oid FROM pg_database WHERE datname = current_database())"
        ).fetchone()[0]
        if waiting:
            return
    raise AssertionError("the flush never waited for a lock")


def _tables_with_rows() -> set[str]:
    tables = connection.introspection.django_table_names(only_existing=True)
    with_rows = set()
    with connection.cursor() as cursor:
        for table in tables:
            cursor.execute(f"SELECT EXISTS (SELECT FROM {connection.ops.quote_name(table)})")
            if cursor.fetchone()[0]:
                with_rows.add(table)
    return with_rows
