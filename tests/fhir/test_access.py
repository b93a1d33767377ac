"""Who may use the FHIR endpoint and what each sees; its CapabilityStatement, Locations and
Devices; its HTTP conventions (media types, `_format`, unknown parameters)."""

import json

import pytest
from django.contrib.auth.models import Group
from django.core.management import call_command
from fhir.resources.R4B.capabilitystatement import CapabilityStatement

from core.access import INTEGRATION
from fhir_r4 import search
from hospital_delivery.models import ApiToken
from scheduling.models import Task
from tests import factories
from tests.fhir.conftest import integration_create, issues, ordered_task

STATION = "https://hospital-delivery.example/fhir/identifier/station"


def bearer(user) -> dict:
    return {"Authorization": f"Bearer {user.api_token_plain}"}


def post_task(client, user, body=None, **headers):
    return client.post(
        "/fhir/r4/Task",
        data=json.dumps(body or ordered_task()),
        content_type=headers.pop("content_type", "application/fhir+json"),
        headers={**bearer(user), **headers},
    )


@pytest.mark.django_db
def test_the_integration_group_exists_after_migrating():
    assert Group.objects.filter(name=INTEGRATION).exists()


@pytest.mark.django_db
def test_nobody_unauthenticated_and_no_nurse_orders(client, site, nurse):
    anonymous = client.get("/fhir/r4/Task")
    assert anonymous.status_code == 401
    assert anonymous.headers["WWW-Authenticate"] == "Bearer"
    assert issues(anonymous.json()) == [("login", [])]
    nurse.api_token_plain = ApiToken.issue(nurse)
    refused = post_task(client, nurse)
    assert refused.status_code == 403
    assert issues(refused.json()) == [("forbidden", [])]
    assert not Task.objects.exists()


@pytest.mark.django_db
def test_an_integration_user_orders_and_reads_but_uses_no_page_and_operates_no_robot(client, site):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    robot = factories.robot_create(site, "R1")
    assert post_task(client, pharmacy).status_code == 201

    assert client.get("/api/v1/tasks/", headers=bearer(pharmacy)).status_code == 403
    client.force_login(pharmacy)
    assert client.get("/").status_code == 403
    pause = client.post(f"/robots/{robot.code}/action", {"action": "pause"})
    assert pause.status_code == 403
    robot.refresh_from_db()
    assert not robot.paused_by_operator


@pytest.mark.django_db
def test_an_integration_user_sees_only_its_sites(client, site):
    other = factories.site_create(site="other", name="Other hospital", members=[])
    here = integration_create("here", sites=[site])
    there = integration_create("there", sites=[other])
    factories.robot_create(other, "R9")
    code = post_task(client, here).json()["id"]

    assert client.get(f"/fhir/r4/Task/{code}", headers=bearer(there)).status_code == 404
    assert client.get("/fhir/r4/Task", headers=bearer(there)).json()["total"] == 0
    assert client.get("/fhir/r4/Device", headers=bearer(here)).json()["total"] == 0
    there_sees = client.get("/fhir/r4/Location", headers=bearer(there)).json()
    assert {e["resource"].get("partOf", {}).get("display", "") for e in there_sees["entry"]} == {
        "",
        "Other hospital",
    }
    refused = client.put(
        f"/fhir/r4/Task/{code}",
        data=json.dumps({**ordered_task(), "id": code, "status": "cancelled"}),
        content_type="application/fhir+json",
        headers=bearer(there),
    )
    assert refused.status_code == 404
    assert Task.objects.get().status == "due"


@pytest.mark.django_db
def test_it_speaks_fhir_json_and_nothing_else(client, site):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    as_json = post_task(client, pharmacy, content_type="application/json")
    assert as_json.status_code == 201
    assert as_json.headers["Content-Type"].startswith("application/fhir+json")
    code = as_json.json()["id"]
    asked = client.get(f"/fhir/r4/Task/{code}?_format=json", headers=bearer(pharmacy))
    assert asked.headers["Content-Type"].startswith("application/fhir+json")
    plain = client.get(f"/fhir/r4/Task/{code}?_format=application/json", headers=bearer(pharmacy))
    assert plain.headers["Content-Type"].startswith("application/json")
    for wanted in ("_format=xml", "_format=application/fhir%2Bxml"):
        refused = client.get(f"/fhir/r4/Task/{code}?{wanted}", headers=bearer(pharmacy))
        assert refused.status_code == 406
        assert issues(refused.json())[0][0] == "not-supported"
    xml_only = client.get(
        f"/fhir/r4/Task/{code}", headers={**bearer(pharmacy), "Accept": "application/fhir+xml"}
    )
    assert xml_only.status_code == 406
    text = post_task(client, pharmacy, content_type="text/plain")
    assert text.status_code == 415
    deleted = client.delete(f"/fhir/r4/Task/{code}", headers=bearer(pharmacy))
    assert deleted.status_code == 405
    assert issues(deleted.json()) == [("not-supported", [])]


@pytest.mark.django_db
def test_it_ignores_unknown_search_parameters_unless_asked_to_be_strict(client, site):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    post_task(client, pharmacy)

    lenient = client.get("/fhir/r4/Task?colour=red&status=requested", headers=bearer(pharmacy))
    strict = client.get(
        "/fhir/r4/Task?colour=red", headers={**bearer(pharmacy), "Prefer": "handling=strict"}
    )
    bad_value = client.get("/fhir/r4/Task?_lastUpdated=yesterday", headers=bearer(pharmacy))

    assert lenient.json()["total"] == 1
    assert "colour" not in lenient.json()["link"][0]["url"]
    assert "status=requested" in lenient.json()["link"][0]["url"]
    assert strict.status_code == 400
    assert issues(strict.json()) == [("not-supported", ["http.colour"])]
    assert bad_value.status_code == 400
    assert issues(bad_value.json()) == [("value", ["http._lastUpdated"])]


@pytest.mark.django_db
def test_its_capability_statement_says_exactly_what_it_supports(client):
    answer = client.get("/fhir/r4/metadata")

    statement = answer.json()
    CapabilityStatement.model_validate(statement)  # a valid R4 CapabilityStatement
    assert statement["fhirVersion"] == "4.0.1"
    resources = {r["type"]: r for r in statement["rest"][0]["resource"]}
    assert set(resources) == {"Task", "Location", "Device"}
    task = resources["Task"]
    interactions = {i["code"] for i in task["interaction"]}
    assert interactions == {"read", "vread", "update", "create", "search-type"}
    assert task["conditionalCreate"] is True
    said = {p["name"] for p in task["searchParam"]}
    assert said == {name for name in search.TASK_PARAMETERS if ":" not in name}
    assert {p["name"] for p in resources["Device"]["searchParam"]} == set(search.DEVICE_PARAMETERS)
    assert {p["name"] for p in resources["Location"]["searchParam"]} == set(
        search.STATION_PARAMETERS
    )


@pytest.mark.django_db(transaction=True)
def test_an_engine_looks_stations_and_robots_up(fhir, site):
    robot = factories.robot_create(site, "R1")

    by_code = fhir.resources("Location").search(identifier=f"{STATION}|2F-LAB").fetch_all()
    by_name = fhir.resources("Location").search(name="pharm").fetch_all()
    robots = fhir.resources("Device").search(identifier="R1").fetch_all()

    assert [loc["name"] for loc in by_code] == ["Laboratory"]
    assert [loc["identifier"][0]["value"] for loc in by_name] == ["1F-PHARM"]
    station = fhir.reference("Location", by_code[0].id).to_resource()
    assert station["partOf"]["identifier"]["value"] == site.code
    site_location = fhir.reference("Location", f"site-{site.pk}").to_resource()
    assert site_location["physicalType"]["coding"][0]["code"] == "si"
    assert [device.id for device in robots] == [f"robot-{robot.pk}"]
    assert robots[0]["status"] == "inactive"  # not heartbeating


@pytest.mark.django_db
def test_user_token_issues_tokens_to_the_integration_group_only(capsys):
    integration_create("lab-system", sites=[])
    factories.user_create("someone")

    call_command("user_token", "lab-system")
    assert len(capsys.readouterr().out.strip()) > 20
    with pytest.raises(Exception, match="integration group"):
        call_command("user_token", "someone")


@pytest.mark.django_db
def test_staff_see_an_orders_references_but_not_the_patients_name(client, site, operator):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    code = post_task(client, pharmacy).json()["id"]
    client.force_login(operator)

    page = client.get(f"/deliveries/{code}/").content.decode()

    assert "MedicationRequest/med-77" in page
    assert "Patient/p-123 · MRN-4711" in page
    assert "Practitioner/dr-lee · Dr Lee" in page
    assert "Kim Minji" not in page


@pytest.mark.django_db
def test_the_order_and_patient_stay_out_of_the_logs(client, site, caplog):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    caplog.set_level("DEBUG")
    post_task(client, pharmacy)
    post_task(client, pharmacy, body={**ordered_task(), "priority": "whenever"})
    client.get("/fhir/r4/Task?patient:identifier=MRN-4711", headers=bearer(pharmacy))

    assert caplog.records  # the request and the allocation were logged
    for secret in ("p-123", "MRN-4711", "med-77", "Kim Minji"):
        assert secret not in caplog.text
