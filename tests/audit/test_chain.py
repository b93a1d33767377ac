"""The hash chain: audit_verify passes on thousands of entries and names the first entry that
was altered, removed or cut from the end; the admin changes and deletes nothing."""

from datetime import timedelta

import pytest
from django.core.management import CommandError, call_command
from django.db import connection
from django.test import override_settings
from django.utils import timezone

from audit.choices import Kind
from audit.models import AuditEntry, ChainHead, EntryNotEditable
from audit.services import entries_sweep, entry_record
from tests import factories
from tests.audit.conftest import logged_in, only_entry

pytestmark = pytest.mark.django_db


def entries_write(count: int, *, site) -> list[AuditEntry]:
    return [entry_record(kind=Kind.CUSTODY_EXPORTED, obj=site, data={"n": n}) for n in range(count)]


def verify() -> str:
    out = []

    class Out:
        def write(self, text):
            out.append(text)

    call_command("audit_verify", stdout=Out())
    return "".join(out)


def sql(statement: str, *params) -> None:
    with connection.cursor() as cursor:
        cursor.execute(statement, params)


def test_it_verifies_a_chain_of_thousands_of_entries(site):
    entries_write(2000, site=site)

    assert verify().startswith(f"{AuditEntry.objects.count()} audit entries verified")
    assert AuditEntry.objects.count() > 2000


def test_it_names_the_entry_altered_in_the_database(site):
    written = entries_write(30, site=site)
    sql("UPDATE audit_auditentry SET object_repr = 'nothing to see' WHERE id = %s", written[17].pk)

    with pytest.raises(CommandError, match=rf"audit entry #{written[17].pk} its content does not"):
        verify()


def test_it_names_the_entry_after_one_deleted_in_the_database(site):
    written = entries_write(10, site=site)
    sql("DELETE FROM audit_auditentry WHERE id = %s", written[4].pk)

    with pytest.raises(CommandError, match=rf"audit entry #{written[5].pk} does not follow"):
        verify()


def test_it_sees_entries_cut_from_the_end(site):
    written = entries_write(5, site=site)
    sql("DELETE FROM audit_auditentry WHERE id >= %s", written[3].pk)

    with pytest.raises(CommandError, match="cut short"):
        verify()


def test_it_refuses_to_change_or_delete_an_entry(site):
    entry = entries_write(1, site=site)[0]
    entry.object_repr = "changed"

    with pytest.raises(EntryNotEditable):
        entry.save()
    with pytest.raises(EntryNotEditable):
        entry.delete()


def test_it_lets_no_superuser_change_or_delete_entries_in_the_admin(site):
    entry = entry_record(kind=Kind.CUSTODY_EXPORTED, obj=site, object_repr="custody of nothing")
    admin = logged_in(factories.staff_create("root", is_superuser=True))
    url = f"/admin/audit/auditentry/{entry.pk}/"

    page = admin.get(f"{url}change/")
    refused_delete = admin.post(f"{url}delete/", {"post": "yes"})
    admin.post(f"{url}change/", {"object_repr": "changed"})

    assert page.status_code == 200
    assert b'name="_save"' not in page.content
    assert refused_delete.status_code == 403
    assert AuditEntry.objects.get(pk=entry.pk).object_repr == "custody of nothing"
    assert b"delete_selected" not in admin.get("/admin/audit/auditentry/").content


@override_settings(AUDIT_RETENTION_DAYS=30)
def test_it_removes_old_entries_records_it_and_still_verifies(site, time_machine):
    time_machine.move_to(timezone.now() - timedelta(days=40), tick=False)
    old = entries_write(3, site=site)
    time_machine.move_to(timezone.now() + timedelta(days=40), tick=False)
    kept = entries_write(2, site=site)
    # The chain is cut at the newest old entry: what was written before it goes too.
    removed = AuditEntry.objects.filter(id__lte=old[-1].pk).count()

    assert entries_sweep(now=timezone.now()) == removed

    sweep = only_entry(Kind.RETENTION_SWEEP)
    assert sweep.additional_data["removed"] == removed
    assert sweep.additional_data["last_id"] == old[-1].pk
    assert not AuditEntry.objects.filter(pk__in=[e.pk for e in old]).exists()
    assert AuditEntry.objects.filter(pk__in=[e.pk for e in kept]).count() == 2
    assert verify().startswith("3 audit entries verified")  # the two kept and the sweep's
    assert ChainHead.objects.get().last_entry_id == sweep.pk


@override_settings(AUDIT_RETENTION_DAYS=0)
def test_it_keeps_every_entry_when_retention_is_zero(site, time_machine):
    time_machine.move_to(timezone.now() - timedelta(days=4000), tick=False)
    entries_write(1, site=site)
    time_machine.move_to(timezone.now() + timedelta(days=4000), tick=False)

    assert entries_sweep(now=timezone.now()) == 0
    assert AuditEntry.objects.filter(kind=Kind.CUSTODY_EXPORTED).count() == 1
