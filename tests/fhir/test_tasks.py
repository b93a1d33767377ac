"""Orders over FHIR with a real FHIR client (fhirpy) against the live server: created, retried,
read, searched, cancelled."""

import threading
from datetime import UTC, datetime, timedelta

import pytest
import requests
from fhirpy.base.exceptions import ForbiddenError

from fhir_r4.models import Order
from scheduling.models import Task
from tests import factories
from tests.fhir.conftest import ORDERS, fhir_client, integration_create, issues, ordered_task

pytestmark = pytest.mark.django_db(transaction=True)


def test_it_creates_a_delivery_from_an_ordered_task(fhir, site, pharmacy):
    created = fhir.resource("Task", **ordered_task()).save().serialize()

    task = Task.objects.get()
    assert created["id"] == task.code
    assert created["status"] == "requested"  # no robot is online to take it
    assert created["businessStatus"]["coding"][0]["code"] == "waiting-for-robot"
    assert created["meta"]["versionId"] == "1"
    assert (task.sender, task.receiver) == ("Pharmacy", "Ward 3")
    assert task.contents == "Morphine 10 mg for ward 3"
    assert [stop.waypoint.code for stop in task.stops.all()] == ["1F-PHARM", "3F-WARD"]
    assert task.requester == pharmacy
    assert created["focus"] == {"reference": "MedicationRequest/med-77"}
    # The patient by reference and identifier only: the name sent is not kept.
    assert created["for"] == {
        "reference": "Patient/p-123",
        "identifier": {"system": "urn:oid:1.2.410.200.1.1", "value": "MRN-4711"},
    }
    assert created["requester"]["display"] == "Dr Lee"
    assert {"system": ORDERS, "value": "RX-1001"} in created["identifier"]
    read = fhir.reference("Task", task.code).to_resource()
    assert read.serialize() == created


def test_it_answers_its_version_headers_and_the_location_of_a_new_task(raw, site):
    response = raw.request("POST", "Task", body=ordered_task())

    assert response.status_code == 201, response.text
    code = response.json()["id"]
    assert response.headers["Content-Type"].startswith("application/fhir+json")
    assert response.headers["ETag"] == 'W/"1"'
    assert response.headers["Location"].endswith(f"/fhir/r4/Task/{code}/_history/1")
    assert raw.request("GET", f"Task/{code}/_history/1").json()["id"] == code
    unchanged = raw.request("GET", f"Task/{code}", headers={"If-None-Match": 'W/"1"'})
    assert unchanged.status_code == 304


def test_it_gives_one_delivery_however_often_an_order_is_retried(fhir, raw, site):
    order = ordered_task(identifier="RX-2002")
    first = fhir.resources("Task").search(identifier=f"{ORDERS}|RX-2002")
    created, was_new = first.get_or_create(fhir.resource("Task", **order))
    again, again_new = first.get_or_create(fhir.resource("Task", **order))
    header = {"If-None-Exist": f"identifier={ORDERS}|RX-2002"}
    by_header = raw.request("POST", "Task", body=order, headers=header)

    assert (was_new, again_new) == (True, False)
    assert again.id == created.id
    assert by_header.status_code == 200
    assert by_header.json()["id"] == created.id
    assert Task.objects.count() == 1
    plain_retry = raw.request("POST", "Task", body=order)  # not conditional: refused
    assert plain_retry.status_code == 409
    assert issues(plain_retry.json()) == [("duplicate", ["Task.identifier[0]"])]
    assert Task.objects.count() == 1


def test_it_gives_one_delivery_when_retries_race(live_server, site, pharmacy):
    """Four retries of one order at once, as an engine whose first request timed out."""
    url = f"{live_server.url}/fhir/r4/Task"
    headers = {
        "Authorization": f"Bearer {pharmacy.api_token_plain}",
        "Content-Type": "application/fhir+json",
        "If-None-Exist": f"identifier={ORDERS}|RX-3003",
    }
    body = ordered_task(identifier="RX-3003")
    start, answers = threading.Barrier(4), []

    def post():
        start.wait()
        answers.append(requests.post(url, json=body, headers=headers, timeout=30))

    threads = [threading.Thread(target=post) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()

    assert sorted(answer.status_code for answer in answers) == [200, 200, 200, 201]
    assert len({answer.json()["id"] for answer in answers}) == 1
    assert Task.objects.count() == Order.objects.count() == 1


def test_it_searches_tasks_by_status_identifier_priority_focus_owner_and_time(fhir, site):
    robot = factories.robot_create(site, "R7")
    routine = fhir.resource("Task", **ordered_task(identifier="RX-1")).save()
    stat = fhir.resource("Task", **ordered_task(identifier="RX-2", priority="stat")).save()
    Task.objects.filter(pk=int(stat.id[2:])).update(robot=robot)
    tasks = fhir.resources("Task")

    def ids(search):
        return sorted(task.id for task in search.fetch_all())

    assert ids(tasks.search(status="requested")) == sorted([routine.id, stat.id])
    assert ids(tasks.search(status="completed,cancelled")) == []
    assert ids(tasks.search(identifier=f"{ORDERS}|RX-2")) == [stat.id]
    assert ids(tasks.search(identifier="RX-1")) == [routine.id]
    assert ids(tasks.search(priority="stat")) == [stat.id]
    assert ids(tasks.search(focus="MedicationRequest/med-77")) == sorted([routine.id, stat.id])
    assert ids(tasks.search(owner=f"Device/robot-{robot.pk}")) == [stat.id]
    newest = datetime.fromisoformat(stat["meta"]["lastUpdated"])
    assert ids(tasks.search(_lastUpdated__gt=newest - timedelta(hours=1))) == ids(tasks)
    exact = fhir.resources("Task").search(_lastUpdated=f"gt{stat['meta']['lastUpdated']}")
    assert ids(exact) == []
    assert ids(tasks.search(_lastUpdated__lt=datetime(2000, 1, 1, tzinfo=UTC))) == []


def test_it_pages_a_search_with_next_links(fhir, site):
    made = {fhir.resource("Task", **ordered_task(identifier=f"P-{n}")).save().id for n in range(5)}

    page = fhir.resources("Task").limit(2).fetch_raw()
    every = fhir.resources("Task").limit(2).fetch_all()

    assert page["total"] == 5
    assert len(page["entry"]) == 2
    assert [link["relation"] for link in page["link"]] == ["self", "next"]
    assert {task.id for task in every} == made


def test_it_cancels_an_order_as_a_nurse_would(fhir, site):
    task = fhir.resource("Task", **ordered_task()).save()
    task["status"] = "cancelled"
    task["statusReason"] = {"text": "Order discontinued by the physician"}

    task.save()

    assert task["status"] == "cancelled"
    assert task["statusReason"]["text"] == "Order discontinued by the physician"
    assert task["meta"]["versionId"] == "2"
    assert Task.objects.get().status == "cancelled"


def test_it_cancels_only_the_version_it_was_asked_about(raw, site):
    created = raw.request("POST", "Task", body=ordered_task()).json()
    cancel = {**created, "status": "cancelled"}

    path = f"Task/{created['id']}"
    stale = raw.request("PUT", path, body=cancel, headers={"If-Match": 'W/"7"'})
    assert stale.status_code == 412
    assert issues(stale.json()) == [("conflict", ["http.If-Match"])]
    assert Task.objects.get().status == "due"

    current = raw.request("PUT", path, body=cancel, headers={"If-Match": 'W/"1"'})
    assert current.status_code == 200
    assert current.headers["ETag"] == 'W/"2"'
    assert Task.objects.get().status == "cancelled"


def test_it_refuses_an_update_other_than_cancelling(raw, site):
    created = raw.request("POST", "Task", body=ordered_task()).json()
    for status in ("completed", "in-progress"):
        response = raw.request("PUT", f"Task/{created['id']}", body={**created, "status": status})
        assert response.status_code == 422
        assert issues(response.json()) == [("business-rule", ["Task.status"])]
    mismatched = raw.request("PUT", f"Task/{created['id']}", body={**created, "id": "T-9999"})
    assert mismatched.status_code == 400
    assert Task.objects.get().status == "due"


def test_only_the_ordering_system_or_an_operator_cancels(live_server, raw, site):
    created = raw.request("POST", "Task", body=ordered_task()).json()
    laboratory = integration_create("lab-system", sites=[site])
    other = fhir_client(live_server.url, laboratory.api_token_plain)

    with pytest.raises(ForbiddenError):
        other.resource("Task", **{**created, "status": "cancelled"}).save()

    assert other.reference("Task", created["id"]).to_resource()["status"] == "requested"
    assert Task.objects.get().status == "due"


def test_it_refuses_to_cancel_a_delivered_task(raw, site):
    created = raw.request("POST", "Task", body=ordered_task()).json()
    Task.objects.update(status="delivered")

    response = raw.request("PUT", f"Task/{created['id']}", body={**created, "status": "cancelled"})

    assert response.status_code == 422
    assert issues(response.json()) == [("business-rule", ["Task.status"])]
    assert Task.objects.get().status == "delivered"
