"""Hospital systems ordering over FHIR: a user of the integration group with an API token, and
a real FHIR client (fhirpy) talking to the live server over HTTP."""

import json
from pathlib import Path

import pytest
import requests
from django.contrib.auth.models import Group
from fhirpy import SyncFHIRClient

from core.access import INTEGRATION
from hospital_delivery.celery import app as celery_app
from hospital_delivery.models import ApiToken
from tests import factories

EXAMPLES = Path(__file__).parent / "examples"
INPUT = "https://hospital-delivery.example/fhir/CodeSystem/task-input"
STATION = "https://hospital-delivery.example/fhir/identifier/station"
ORDERS = "urn:oid:1.2.410.200.1.4.11"  # a pharmacy system's order numbers (made up)


@pytest.fixture(autouse=True)
def eager_allocation():
    """Tasks the worker would allocate (none waits here) are allocated at once, in process."""
    celery_app.conf.task_always_eager = True
    yield
    celery_app.conf.task_always_eager = False


def integration_create(username: str, *, sites):
    """A hospital system's user: in the integration group, a member of `sites`, with a token
    (user.api_token_plain)."""
    user = factories.user_create(username, sites=sites)
    user.groups.add(Group.objects.get_or_create(name=INTEGRATION)[0])
    user.api_token_plain = ApiToken.issue(user)
    return user


@pytest.fixture
def pharmacy(site):
    return integration_create("pharmacy-system", sites=[site])


def fhir_client(base_url: str, token: str, **headers) -> SyncFHIRClient:
    return SyncFHIRClient(
        f"{base_url}/fhir/r4",
        authorization=f"Bearer {token}",
        extra_headers=headers or None,
        requests_config={"timeout": 30},
    )


@pytest.fixture
def fhir(live_server, pharmacy):
    return fhir_client(live_server.url, pharmacy.api_token_plain)


class RawFhir:
    """Bodies and headers a FHIR client would never send, over real HTTP."""

    def __init__(self, base_url: str, token: str | None):
        self.base = f"{base_url}/fhir/r4"
        self.session = requests.Session()
        if token:
            self.session.headers["Authorization"] = f"Bearer {token}"

    def request(self, method: str, path: str, *, body=None, raw: bytes | None = None, **kw):
        headers = {"Content-Type": "application/fhir+json", **kw.pop("headers", {})}
        data = raw if raw is not None else (None if body is None else json.dumps(body))
        url = f"{self.base}/{path}"
        return self.session.request(method, url, data=data, headers=headers, timeout=30, **kw)


@pytest.fixture
def raw(live_server, pharmacy):
    return RawFhir(live_server.url, pharmacy.api_token_plain)


def example(name: str) -> dict:
    return json.loads((EXAMPLES / name).read_text())


def ordered_task(
    *,
    pickup: str = "1F-PHARM",
    dropoff: str = "3F-WARD",
    identifier: str | None = "RX-1001",
    priority: str = "routine",
    **extra,
) -> dict:
    """A pharmacy's order for a delivery, as an interface engine sends it."""
    task = {
        "resourceType": "Task",
        "status": "requested",
        "intent": "order",
        "priority": priority,
        "description": "Morphine 10 mg for ward 3",
        "focus": {"reference": "MedicationRequest/med-77", "display": "Morphine 10 mg"},
        "for": {
            "reference": "Patient/p-123",
            "identifier": {"system": "urn:oid:1.2.410.200.1.1", "value": "MRN-4711"},
            "display": "Kim Minji",
        },
        "requester": {"reference": "Practitioner/dr-lee", "display": "Dr Lee"},
        "input": [
            _input("pickup", {"identifier": {"system": STATION, "value": pickup}}),
            _input("dropoff", {"identifier": {"system": STATION, "value": dropoff}}),
        ],
    }
    if identifier is not None:
        task["identifier"] = [{"system": ORDERS, "value": identifier}]
    task.update(extra)
    return task


def _input(kind: str, reference: dict) -> dict:
    return {"type": {"coding": [{"system": INPUT, "code": kind}]}, "valueReference": reference}


def secure_inputs(recipient: str = "Nurse Park") -> list[dict]:
    return [
        {"type": {"coding": [{"system": INPUT, "code": "secure"}]}, "valueBoolean": True},
        {"type": {"coding": [{"system": INPUT, "code": "recipient"}]}, "valueString": recipient},
    ]


def issues(outcome: dict) -> list[tuple[str, list[str]]]:
    """(code, expressions) of each issue of an OperationOutcome."""
    assert outcome["resourceType"] == "OperationOutcome", outcome
    return [(issue["code"], issue.get("expression", [])) for issue in outcome["issue"]]
