"""The auditors' page and its exports: an auditor sees the entries of their sites only, nurses
and operators nothing; filters and bad input; exports are safe to open and are audited."""

import csv
import io

import pytest
from django.utils import timezone

from audit.choices import Kind
from audit.models import AuditEntry
from audit.services import entry_record
from tests import factories
from tests.audit.conftest import logged_in, only_entry

pytestmark = pytest.mark.django_db

TODAY = timezone.localdate


@pytest.fixture
def other_site(site):
    return factories.site_create(site="north", members=[])


@pytest.fixture
def written(site, other_site, nurse):
    """One export at each site, and a sign-in of no site."""
    here = entry_record(kind=Kind.CUSTODY_EXPORTED, obj=site, object_repr="=HYPERLINK(x)")
    there = entry_record(kind=Kind.CUSTODY_EXPORTED, obj=other_site, object_repr="north export")
    nowhere = entry_record(kind=Kind.SIGN_IN, obj=nurse, actor=nurse)
    return here, there, nowhere


def export(client, extension="csv", **query):
    days = {"start": TODAY().isoformat(), "end": TODAY().isoformat()}
    return client.get(f"/audit/entries.{extension}", {**days, **query})


def csv_ids(response) -> set[int]:
    rows = list(csv.reader(io.StringIO(response.content.decode())))
    assert rows[0][0] == "entry"
    return {int(row[0]) for row in rows[1:]}


def page_ids(response) -> set[int]:
    return {entry.pk for entry in response.context["page"]}


def test_it_shows_an_auditor_the_entries_of_their_sites_only(auditor, written):
    here, there, nowhere = written
    client = logged_in(auditor)

    page = client.get("/audit/")
    exported = export(client)

    assert page.status_code == 200
    assert here.pk in page_ids(page)
    assert not {there.pk, nowhere.pk} & page_ids(page)
    assert here.pk in csv_ids(exported)
    assert not {there.pk, nowhere.pk} & csv_ids(exported)


def test_it_shows_an_administrator_every_entry(written):
    client = logged_in(factories.staff_create("root"))

    assert {e.pk for e in written} <= page_ids(client.get("/audit/"))
    assert {e.pk for e in written} <= csv_ids(export(client))


def test_it_refuses_nurses_and_operators_the_page_and_its_exports(nurse, operator, written):
    for user in (nurse, operator):
        client = logged_in(user)
        assert client.get("/audit/").status_code == 403
        assert export(client).status_code == 403
        assert export(client, "json").status_code == 403


def test_it_refuses_an_auditor_a_site_that_is_not_theirs(auditor, other_site, written):
    response = export(logged_in(auditor), site=other_site.code)

    assert response.status_code == 400
    assert "site" in response.json()["detail"]


def test_it_filters_by_person_kind_and_days(auditor, site, operator, written):
    mine = entry_record(kind=Kind.OPERATOR_ACTION, obj=site, actor=operator)
    client = logged_in(auditor)

    by_person = page_ids(client.get("/audit/", {"person": "park"}))
    by_kind = page_ids(client.get("/audit/", {"kind": Kind.OPERATOR_ACTION}))
    yesterday = (TODAY() - timezone.timedelta(days=1)).isoformat()
    before_today = page_ids(client.get("/audit/", {"start": yesterday, "end": yesterday}))

    assert by_person == {mine.pk}
    assert mine.pk in by_kind
    assert written[0].pk not in by_kind
    assert before_today == set()


def test_it_refuses_bad_dates_naming_them_and_records_no_export(auditor, written):
    client = logged_in(auditor)

    backwards = export(client, start="2026-11-02", end="2026-11-01")
    nonsense = export(client, start="yesterday")
    missing = client.get("/audit/entries.csv")
    page = client.get("/audit/", {"end": "9999-01-01"})

    assert backwards.status_code == 400
    assert list(backwards.json()["detail"]) == ["end"]
    assert list(nonsense.json()["detail"]) == ["start"]
    assert set(missing.json()["detail"]) == {"start", "end"}
    assert page.status_code == 400
    assert "end" in page.context["form"].errors
    assert not AuditEntry.objects.filter(kind=Kind.AUDIT_EXPORTED).exists()


def test_it_writes_csv_cells_as_text_and_records_the_export(auditor, site, written):
    response = export(logged_in(auditor), site=site.code)

    rows = list(csv.reader(io.StringIO(response.content.decode())))
    objects = [row[9] for row in rows[1:]]
    assert "'=HYPERLINK(x)" in objects
    exported = only_entry(Kind.AUDIT_EXPORTED)
    assert (exported.actor, exported.site_id) == (auditor, site.pk)
    assert exported.additional_data["rows"] == len(rows) - 1


def test_it_exports_json(auditor, written):
    response = export(logged_in(auditor), "json")

    records = response.json()
    assert response["Content-Type"] == "application/json"
    assert written[0].pk in {record["entry"] for record in records}
    assert {record["hash"] for record in records if record["entry"] == written[0].pk} == {
        written[0].entry_hash
    }
