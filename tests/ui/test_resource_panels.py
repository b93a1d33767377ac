"""The fleet page's lift and door panels and their operators' controls."""

import re

import pytest

from building.models import Device
from building.services import devices_ensure
from robots.models import Resource
from scheduling.models import OperatorAction


@pytest.fixture
def devices(site):
    devices_ensure(site=site)
    return {device.resource.code: device for device in Device.objects.select_related("resource")}


def row(html: str, code: str) -> str:
    return re.search(rf'<tr data-resource="{code}".*?</tr>', html, re.S).group(0)


def test_it_shows_the_car_and_doors_with_the_operators_controls(operator_client, devices):
    html = operator_client.get("/fleet/").content.decode()
    lift = row(html, "ELEV")
    assert "Car at <strong data-car-floor>1F</strong>" in lift
    assert "<strong data-doors>closed</strong>" in lift
    assert "Take out of service" in lift
    assert "Hold doors" in lift
    assert "Send car" in lift
    assert "Door" in row(html, "DOOR-2F")
    assert "Send car" not in row(html, "DOOR-2F")
    assert "data-device" not in row(html, "CORR-3F")  # corridors have no device


def test_nurses_see_the_panel_without_the_controls(nurse_client, devices):
    lift = row(nurse_client.get("/fleet/").content.decode(), "ELEV")
    assert "data-car-floor" in lift
    assert "Take out of service" not in lift
    assert "Hold doors" not in lift


def test_an_operator_takes_a_lift_out_of_service_and_back(operator_client, operator, site):
    taken = operator_client.post(
        "/resources/tiny/ELEV/service", {"in_service": "false", "reason": "stuck doors"}
    )
    assert taken.status_code == 302
    lift = Resource.objects.get(site=site, code="ELEV")
    assert (lift.in_service, lift.out_of_service_reason) == (False, "stuck doors")
    html = row(operator_client.get("/fleet/").content.decode(), "ELEV")
    assert "Out of service" in html
    assert "stuck doors" in html
    assert "Return to service" in html

    operator_client.post("/resources/tiny/ELEV/service", {"in_service": "true"})
    lift.refresh_from_db()
    assert lift.in_service
    assert list(OperatorAction.objects.values_list("action", "by")) == [
        ("back_in_service", operator.pk),
        ("out_of_service", operator.pk),
    ]


def test_an_operator_holds_the_doors_and_sends_the_car(operator_client, devices):
    assert operator_client.post("/resources/tiny/ELEV/doors", {"hold": "true"}).status_code == 302
    assert operator_client.post("/resources/tiny/ELEV/car", {"floor": "3F"}).status_code == 302
    lift = Device.objects.get(pk=devices["ELEV"].pk)
    assert lift.held_by_operator
    assert lift.requested_floor.code == "3F"
    assert lift.request_seq == 2


def test_lift_and_door_commands_are_recorded_with_who_when_and_what(
    operator_client, operator, devices
):
    operator_client.post("/resources/tiny/ELEV/doors", {"hold": "true"})
    operator_client.post("/resources/tiny/ELEV/car", {"floor": "3F"})
    operator_client.post("/resources/tiny/ELEV/doors", {"hold": "false"})

    actions = OperatorAction.objects.order_by("id")
    assert [(a.resource.code, a.action, a.by_id, a.note) for a in actions] == [
        ("ELEV", "hold_doors", operator.pk, ""),
        ("ELEV", "send_car", operator.pk, "3F"),
        ("ELEV", "release_doors", operator.pk, ""),
    ]
    assert all(a.at is not None and a.robot is None for a in actions)


@pytest.mark.parametrize(
    ("path", "body", "field"),
    [
        ("ELEV/service", {"in_service": "false"}, "reason"),
        ("ELEV/service", {"in_service": "false", "reason": "x" * 201}, "reason"),
        ("ELEV/service", {"in_service": "maybe", "reason": "x"}, "in_service"),
        ("ELEV/service", {}, "in_service"),
        ("ELEV/doors", {"hold": "please"}, "hold"),
        ("ELEV/car", {"floor": "4F"}, "floor"),  # the lift does not stop there
        ("ELEV/car", {"floor": ""}, "floor"),
        ("DOOR-2F/car", {"floor": "2F"}, "floor"),  # a door has no car
    ],
)
def test_it_refuses_bad_input_naming_the_field_and_changes_nothing(
    operator_client, devices, site, path, body, field
):
    before = {d.pk: (d.request_seq, d.held_by_operator) for d in Device.objects.all()}
    response = operator_client.post(f"/resources/tiny/{path}", body)
    assert response.status_code == 400
    assert response.json()["error"] == "invalid"
    assert field in response.json()["detail"]
    assert all(r.in_service for r in Resource.objects.filter(site=site))
    assert {d.pk: (d.request_seq, d.held_by_operator) for d in Device.objects.all()} == before
    assert not OperatorAction.objects.exists()


def test_it_refuses_nurses_unknown_resources_and_corridor_controls(
    nurse_client, operator_client, site, devices
):
    assert (
        nurse_client.post(
            "/resources/tiny/ELEV/service", {"in_service": "false", "reason": "x"}
        ).status_code
        == 403
    )
    assert (
        operator_client.post("/resources/tiny/NOPE/service", {"in_service": "true"}).status_code
        == 404
    )
    assert (
        operator_client.post("/resources/elsewhere/ELEV/doors", {"hold": "true"}).status_code == 404
    )
    assert (
        operator_client.post("/resources/tiny/CORR-3F/doors", {"hold": "true"}).status_code == 404
    )
    assert operator_client.get("/resources/tiny/ELEV/service").status_code == 405
    assert all(r.in_service for r in Resource.objects.filter(site=site))
    assert Device.objects.filter(held_by_operator=True).count() == 0
