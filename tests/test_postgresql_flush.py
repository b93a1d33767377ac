"""The tests' PostgreSQL backend (tests/postgresql/base.py) empties the database as Django's
flush does: every table but the content types and permissions, which stay as post_migrate
makes them."""

import pytest
from django.contrib.auth.models import Permission
from django.contrib.contenttypes.models import ContentType
from django.core.management import call_command
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


def _tables_with_rows() -> set[str]:
    tables = connection.introspection.django_table_names(only_existing=True)
    with_rows = set()
    with connection.cursor() as cursor:
        for table in tables:
            cursor.execute(f"SELECT EXISTS (SELECT FROM {connection.ops.quote_name(table)})")
            if cursor.fetchone()[0]:
                with_rows.add(table)
    return with_rows
