"""Auditors, and the audit entries a test's actions wrote."""

import pytest
from django.test import Client

from audit.models import AuditEntry
from tests import factories, servers


@pytest.fixture(scope="session", autouse=True)
def celery_sink_queue():
    with servers.celery_sink("audit") as queue:
        yield queue


@pytest.fixture
def auditor(site):
    return factories.user_create("ines", "auditor", sites=[site])


def logged_in(user) -> Client:
    client = Client()
    client.force_login(user)
    return client


def newest_id() -> int:
    """The id of the newest entry: what a test's setup wrote is before it."""
    return AuditEntry.objects.order_by("-id").values_list("id", flat=True).first() or 0


def entries(kind: str, **filters) -> list[AuditEntry]:
    return list(AuditEntry.objects.filter(kind=kind, **filters).order_by("id"))


def only_entry(kind: str, **filters) -> AuditEntry:
    found = entries(kind, **filters)
    assert len(found) == 1, [(e.pk, e.object_repr) for e in found]
    return found[0]
