"""The resources' service over the API: out of service and back, recorded; bad input is a 4xx
in the error shape naming the field, and changes nothing."""

import pytest
from django.test import Client

from robots.models import Alert, Resource
from scheduling.models import OperatorAction
from tests import factories

URL = "/api/v1/sites/tiny/resources/"


@pytest.fixture
def api(staff):
    return Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")


def post(client, path, body=None):
    return client.post(f"{URL}{path}", body, content_type="application/json")


def unchanged(site) -> bool:
    resources = Resource.objects.filter(site=site)
    in_service = all(resource.in_service for resource in resources)
    return in_service and not OperatorAction.objects.exists() and not Alert.objects.exists()


def test_it_takes_a_resource_out_of_service_and_returns_it(api, site, staff):
    taken = post(api, "ELEV/out-of-service", {"reason": "annual inspection"})
    assert taken.status_code == 200, taken.content
    assert taken.json() | {"out_of_service_since": None} == {
        "site": "tiny",
        "code": "ELEV",
        "kind": "elevator",
        "in_service": False,
        "out_of_service_since": None,
        "out_of_service_reason": "annual inspection",
        "priority_since": None,
        "priority_reason": "",
    }
    assert taken.json()["out_of_service_since"]
    listed = {each["code"]: each["in_service"] for each in api.get(URL).json()}
    assert listed == {"CORR-3F": True, "DOOR-2F": True, "ELEV": False}
    again = post(api, "ELEV/out-of-service", {"reason": "twice"})
    assert (again.status_code, again.json()["error"]) == (409, "conflict")

    back = post(api, "ELEV/return-to-service")
    assert back.status_code == 200, back.content
    assert back.json()["in_service"] is True
    assert post(api, "ELEV/return-to-service").status_code == 409
    actions = OperatorAction.objects.order_by("pk")
    assert [(a.action, a.resource.code, a.by) for a in actions] == [
        ("out_of_service", "ELEV", staff),
        ("back_in_service", "ELEV", staff),
    ]
    assert not Alert.objects.open().exists()  # the out-of-service alert closed on return


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({}, "reason"),
        ({"reason": ""}, "reason"),
        ({"reason": 7}, "reason"),
        ({"reason": None}, "reason"),
        ({"reason": "x" * 201}, "reason"),
        ([], "body"),
    ],
)
def test_it_refuses_a_bad_reason_naming_the_field(api, site, body, field):
    response = post(api, "ELEV/out-of-service", body)
    assert response.status_code == 400, response.content
    assert response.json()["error"] == "invalid"
    assert field in response.json()["detail"]
    assert unchanged(site)


def test_it_refuses_bad_json_and_unknown_things(api, site):
    raw = api.post(f"{URL}ELEV/out-of-service", b"{", content_type="application/json")
    assert (raw.status_code, raw.json()["error"]) == (400, "invalid_json")
    unknown = post(api, "LIFT-9/out-of-service", {"reason": "x"})
    assert (unknown.status_code, unknown.json()["error"]) == (404, "not_found")
    assert post(api, "LIFT-9/return-to-service").status_code == 404
    assert api.get("/api/v1/sites/nowhere/resources/").status_code == 404
    other = post(api, "ELEV%00/out-of-service", {"reason": "x"})
    assert 400 <= other.status_code < 500
    assert unchanged(site)


def test_it_refuses_anonymous_and_non_staff_users(site):
    nurse = factories.staff_create("nurse", is_staff=False)
    for client, expected in (
        (Client(), 401),
        (Client(HTTP_AUTHORIZATION=f"Bearer {nurse.api_token_plain}"), 403),
    ):
        assert post(client, "ELEV/out-of-service", {"reason": "x"}).status_code == expected
        assert post(client, "ELEV/return-to-service").status_code == expected
        assert client.get(URL).status_code == expected
    assert unchanged(site)
