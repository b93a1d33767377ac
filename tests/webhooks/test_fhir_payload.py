"""Subscriptions that chose the FHIR payload receive the changed delivery as a FHIR R4 Task, as
it is at the change, signed like every delivery."""

import json

import pytest
from fhir.resources.R4B.task import Task as FhirTask

from scheduling.services import task_allocate
from tests import factories
from tests.fhir.conftest import integration_create, ordered_task
from tests.scheduling.conftest import robot_ready
from tests.webhooks.conftest import subscribe
from tests.webhooks.receiver import HookReceiver
from webhooks.models import WebhookDelivery
from webhooks.services import delivery_send

pytestmark = pytest.mark.django_db


def test_a_fhir_subscription_receives_the_task_as_it_is_at_each_change(site, client, sent):
    fhir = subscribe(site, "http://127.0.0.1:9/fhir", payload_format="fhir", name="Pharmacy")
    native = subscribe(site, "http://127.0.0.1:9/native")
    pharmacy = integration_create("pharmacy-system", sites=[site])
    robot = factories.robot_create(site, "R1")
    answer = client.post(
        "/fhir/r4/Task",
        data=json.dumps(ordered_task()),
        content_type="application/fhir+json",
        headers={"Authorization": f"Bearer {pharmacy.api_token_plain}"},
    )
    assert answer.status_code == 201, answer.content
    robot_ready(robot)
    task_allocate(task_id=int(answer.json()["id"][2:]))

    told = [d.payload for d in WebhookDelivery.objects.filter(subscription=fhir).order_by("pk")]
    assert [(t["status"], t["meta"]["versionId"]) for t in told] == [
        ("requested", "1"),
        ("accepted", "2"),
    ]
    for payload in told:
        FhirTask.model_validate(payload)  # a valid R4 Task
    assert told[-1]["owner"]["reference"] == f"Device/robot-{robot.pk}"
    assert told[-1]["for"]["reference"] == "Patient/p-123"
    natives = WebhookDelivery.objects.filter(subscription=native).order_by("pk")
    assert [d.payload["task"]["status"] for d in natives] == ["due", "assigned"]
    assert {d.event_id for d in natives} == {
        d.event_id for d in WebhookDelivery.objects.filter(subscription=fhir)
    }


def test_a_fhir_payload_is_sent_signed_as_fhir_json(site, client, sent):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    with HookReceiver() as receiver:
        subscription = subscribe(site, receiver.url, payload_format="fhir")
        client.post(
            "/fhir/r4/Task",
            data=json.dumps(ordered_task()),
            content_type="application/fhir+json",
            headers={"Authorization": f"Bearer {pharmacy.api_token_plain}"},
        )
        delivery = WebhookDelivery.objects.get(subscription=subscription)

        assert delivery_send(delivery_id=delivery.pk) is True

    received = receiver.accepted()[0]
    assert received.signed_with(subscription.secret)
    assert received.payload["resourceType"] == "Task"
    assert received.content_type == "application/fhir+json"
