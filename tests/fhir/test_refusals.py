"""What the endpoint refuses, always as an OperationOutcome naming the element, nothing written:
the FHIR specification's own example Tasks and Locations, and hostile bodies.

tests/fhir/examples/ holds the R4 (4.0.1) examples as published at http://hl7.org/fhir/R4/
(task-example1.json ... location-example-room.json), copied from the mirror of the R4
specification in the public repository github.com/fhir-ru/fhir-ru.github.io (commit 73deef62,
its version.info: FhirVersion=4.0.1).
"""

import json

import pytest
from fhir.resources.R4B.location import Location
from fhirpy.base.exceptions import OperationOutcome

from fhir_r4.models import Order
from scheduling.models import Task, TaskStop, TaskTransition
from tests import factories
from tests.fhir.conftest import (
    EXAMPLES,
    STATION,
    RawFhir,
    example,
    integration_create,
    issues,
)
from tests.fhir.conftest import ordered_task as order

pytestmark = pytest.mark.django_db(transaction=True)

TASK_EXAMPLES = sorted(path.name for path in EXAMPLES.glob("task-example*.json"))
LOCATION_EXAMPLES = sorted(path.name for path in EXAMPLES.glob("location-example*.json"))


def counts() -> tuple[int, ...]:
    return tuple(m.objects.count() for m in (Task, TaskStop, TaskTransition, Order))


@pytest.fixture
def unchanged(site):
    before = counts()
    yield
    assert counts() == before


def test_the_examples_are_there():
    assert len(TASK_EXAMPLES) == 12
    assert len(LOCATION_EXAMPLES) == 6


def test_it_refuses_each_published_example_task_naming_why(fhir, unchanged):
    """None of them orders a delivery: none has our pickup and dropoff inputs; some are not
    new (status in-progress, completed) or not orders (intent filler-order). Each is read
    (all are valid R4, so they pass validation) and refused for what it lacks."""
    for name in TASK_EXAMPLES:
        sent = {key: value for key, value in example(name).items() if key != "id"}  # a create
        with pytest.raises(OperationOutcome) as refused:
            fhir.resource("Task", **sent).save()

        found = issues(refused.value.resource)
        assert ("required", ["Task.input"]) in found, (name, found)
        assert all(paths and paths[0].startswith("Task.") for _, paths in found), name


def test_each_published_example_location_is_a_location_nobody_can_order_to(raw, unchanged):
    """Valid R4 Locations (so validated as ours are), which the endpoint serves and never
    takes: a POST is refused, and a Task naming one as a stop is refused at that input."""
    for name in LOCATION_EXAMPLES:
        _location_refused(raw, example(name))


def _location_refused(raw, location: dict) -> None:
    Location.model_validate(location)

    posted = raw.request("POST", "Location", body=location)
    assert posted.status_code == 405
    assert issues(posted.json())[0][0] == "not-supported"

    named = [{"identifier": i} for i in location.get("identifier", [])] or [
        {"reference": f"Location/{location['id']}"}
    ]
    body = order()
    body["input"][1]["valueReference"] = named[0]
    refused = raw.request("POST", "Task", body=body)
    assert refused.status_code == 422, refused.text
    assert [paths for _, paths in issues(refused.json())] == [["Task.input[1].valueReference"]]


HOSTILE = {
    "a Location instead of a Task": (
        {"resourceType": "Location", "name": "x"},
        400,
        ["resourceType"],
    ),
    "no resourceType": ({"status": "requested"}, 400, ["resourceType"]),
    "an unknown element": ({**order(), "robot": "R1"}, 400, ["Task.robot"]),
    "an unknown element deep inside": (
        {**order(), "focus": {"reference": "MedicationRequest/1", "colour": "red"}},
        400,
        ["Task.focus.colour"],
    ),
    "a wrong type": ({**order(), "priority": ["stat"]}, 400, ["Task.priority"]),
    "an unknown contained resource type": (
        {**order(), "contained": [{"resourceType": "Robot"}]},
        400,
        ["Task.contained[0]"],
    ),
    "a station that does not exist": (
        {
            **order(),
            "input": [
                order()["input"][0],
                {
                    **order()["input"][1],
                    "valueReference": {"identifier": {"system": STATION, "value": "9F-NOPE"}},
                },
            ],
        },
        422,
        ["Task.input[1].valueReference"],
    ),
    "a station by a reference that is not ours": (
        {
            **order(),
            "input": [{**order()["input"][0], "valueReference": {"reference": "Location/1"}}]
            + order()["input"][1:],
        },
        422,
        ["Task.input[0].valueReference"],
    ),
    "an unsupported priority": ({**order(), "priority": "whenever"}, 422, ["Task.priority"]),
    "a status other than requested": ({**order(), "status": "completed"}, 422, ["Task.status"]),
    "a deadline as a date alone": (
        {**order(), "restriction": {"period": {"end": "2030-01-01"}}},
        422,
        ["Task.restriction.period.end"],
    ),
    "a deadline passed": (
        {**order(), "restriction": {"period": {"end": "2001-01-01T10:00:00+09:00"}}},
        422,
        ["Task.restriction.period.end"],
    ),
    "a secure delivery without its recipient": (
        {
            **order(),
            "input": [
                *order()["input"],
                {
                    "type": {"coding": [{"code": "secure"}]},
                    "valueBoolean": True,
                },
            ],
        },
        422,
        ["Task.input"],
    ),
    "nothing said of what is carried": (
        {k: v for k, v in order().items() if k != "description"},
        422,
        ["Task.description"],
    ),
}


def test_it_refuses_hostile_tasks_naming_the_element(raw, unchanged):
    for case, (body, status, paths) in HOSTILE.items():
        response = raw.request("POST", "Task", body=body)

        assert response.status_code == status, (case, response.text)
        assert response.headers["Content-Type"].startswith("application/fhir+json")
        assert paths in [found for _, found in issues(response.json())], case


UNREADABLE = [
    (b"[" * 5000 + b"]" * 5000, 400),  # nested past any FHIR resource
    (b'{"resourceType": "Task", "description": "' + b"x" * 300_000 + b'"}', 413),
    (b'{"resourceType": "Task", "status": ', 400),  # not JSON
    (b'{"resourceType": "Task", "description": "\\u0000"}', 400),  # NUL
    (b'{"resourceType": "Task", "description": "\\ud800"}', 400),  # lone surrogate
    (b"[1, 2]", 400),
]


def test_it_refuses_bodies_it_cannot_read(raw, unchanged):
    for raw_body, status in UNREADABLE:
        response = raw.request("POST", "Task", raw=raw_body)

        assert response.status_code == status, raw_body[:40]
        assert issues(response.json())


def test_it_refuses_a_station_of_another_site_as_if_unknown(live_server, site, unchanged):
    other = factories.site_create(site="other", name="Other hospital", members=[])
    pharmacy = integration_create("other-pharmacy", sites=[site])
    body = order()
    elsewhere = other.waypoints.get(code="3F-WARD")
    body["input"][1]["valueReference"] = {"reference": f"Location/station-{elsewhere.pk}"}
    response = RawFhir(live_server.url, pharmacy.api_token_plain).request("POST", "Task", body=body)

    assert response.status_code == 422
    assert issues(response.json()) == [("not-found", ["Task.input[1].valueReference"])]
    assert f"station-{elsewhere.pk}" in json.dumps(response.json())


def test_it_refuses_stations_of_two_sites_in_one_task(live_server, site, unchanged):
    other = factories.site_create(site="other", name="Other hospital", members=[])
    both = integration_create("two-site-pharmacy", sites=[site, other])
    body = order()
    body["input"][1]["valueReference"] = {
        "reference": f"Location/station-{other.waypoints.get(code='3F-WARD').pk}"
    }
    body["input"][0]["valueReference"] = {
        "reference": f"Location/station-{site.waypoints.get(code='1F-PHARM').pk}"
    }
    response = RawFhir(live_server.url, both.api_token_plain).request("POST", "Task", body=body)

    assert response.status_code == 422
    assert issues(response.json()) == [("invalid", ["Task.input[1].valueReference"])]
