"""Webhooks: each status change of a task stored as a delivery in the change's own transaction,
POSTed signed, retried with back-off until answered, de-duplicable by its event id."""

from datetime import timedelta

import pytest
from django.core.exceptions import ValidationError
from django.db import connection, transaction
from django.test import Client
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from scheduling.models import TaskTransition
from scheduling.services import site_allocate_due, task_allocate, task_cancel
from tests import factories
from tests.factories import heartbeat_apply_now
from tests.scheduling.conftest import event as task_event
from tests.scheduling.conftest import request as task_request
from tests.scheduling.conftest import robot_ready
from tests.webhooks.conftest import subscribe
from tests.webhooks.receiver import HookReceiver
from webhooks.models import WebhookDelivery
from webhooks.services import FIRST_RETRY_SECONDS, MAX_ATTEMPTS, delivery_send, retry_delay
from webhooks.signing import signature, signature_valid

pytestmark = pytest.mark.django_db


def test_it_stores_a_delivery_for_each_status_change_in_the_same_transaction(site, sent):
    subscription = subscribe(site, "http://127.0.0.1:9/hook")
    robot_ready(factories.robot_create(site, "R1"))

    def request_rolled_back():
        with transaction.atomic():
            task_request(site)
            raise RuntimeError("the request rolls back")

    with pytest.raises(RuntimeError):
        request_rolled_back()
    assert not WebhookDelivery.objects.exists()  # nothing of a rolled-back change

    task = task_request(site)
    task_allocate(task_id=task.pk)

    history = TaskTransition.objects.filter(task=task).order_by("pk")
    moves = [(entry.old, entry.new) for entry in history if entry.old != entry.new]
    deliveries = list(WebhookDelivery.objects.filter(subscription=subscription).order_by("pk"))
    told = [
        (d.payload["task"]["previous_status"] or "", d.payload["task"]["status"])
        for d in deliveries
    ]
    assert told == moves == [("", "due"), ("due", "assigned")]
    assert len({d.event_id for d in deliveries}) == len(deliveries)
    assert deliveries[-1].payload["task"]["robot"] == "R1"
    assert deliveries[-1].payload["site"] == site.code


def test_it_sends_only_the_statuses_asked_for_and_nothing_to_inactive_subscriptions(site, sent):
    cancelled = subscribe(site, "http://127.0.0.1:9/a", statuses=["cancelled"])
    subscribe(site, "http://127.0.0.1:9/b", active=False)
    user = factories.staff_create()

    task = task_request(site)
    task_cancel(task=task, by=user)

    [delivery] = WebhookDelivery.objects.all()
    assert delivery.subscription == cancelled
    assert delivery.payload["task"]["status"] == "cancelled"


def test_a_batch_reads_the_subscriptions_once_and_tells_each_change_to_each_of_them(site, sent):
    # A burst's batch moves every task it assigns: one read of the site's subscriptions for
    # all of them (core.memo), not one per task; and nothing kept past the batch.
    first = subscribe(site, "http://127.0.0.1:9/a")
    for code in ("R1", "R2", "R3"):
        robot_ready(factories.robot_create(site, code))
    tasks = [task_request(site) for _ in range(3)]

    with CaptureQueriesContext(connection) as queries:
        assert site_allocate_due(site_id=site.pk) == 3

    reads = [q for q in queries.captured_queries if '"webhooks_subscription"' in q["sql"]]
    assert len(reads) == 1
    assigned = WebhookDelivery.objects.filter(payload__task__status="assigned")
    assert sorted(d.payload["task"]["code"] for d in assigned) == sorted(t.code for t in tasks)
    second = subscribe(site, "http://127.0.0.1:9/b")
    task_cancel(task=tasks[0], by=factories.staff_create())
    cancelled = WebhookDelivery.objects.filter(payload__task__status="cancelled")
    assert {d.subscription for d in cancelled} == {first, second}


def test_a_heartbeat_reporting_a_delivery_reads_the_subscriptions_once(site, sent):
    subscribe(site, "http://127.0.0.1:9/a")
    robot = factories.robot_create(site, "R1")
    robot_ready(robot)
    task = task_request(site)
    task_allocate(task_id=task.pk)
    events = [
        task_event("loaded", task.code, 0),
        task_event("unloaded", task.code, 1),
        task_event("task_completed", task.code),
    ]

    with CaptureQueriesContext(connection) as queries:
        heartbeat_apply_now(robot, now=timezone.now(), events=events)

    reads = [q for q in queries.captured_queries if '"webhooks_subscription"' in q["sql"]]
    assert len(reads) == 1
    told = [d.payload["task"]["status"] for d in WebhookDelivery.objects.order_by("pk")]
    assert told[-4:] == ["acknowledged", "picked_up", "delivered", "completed"]


def test_it_refuses_unknown_statuses_naming_the_field(site):
    with pytest.raises(ValidationError) as refused:
        subscribe(site, "http://127.0.0.1:9/hook", statuses=["picked_up", "lost"])
    assert "lost" in refused.value.message_dict["statuses"][0]


def test_it_posts_a_signed_body_with_a_stable_event_id(site, sent):
    with HookReceiver() as receiver:
        subscription = subscribe(site, receiver.url)
        task_request(site)
        delivery = WebhookDelivery.objects.get()

        assert delivery_send(delivery_id=delivery.pk) is True

    [got] = receiver.received
    assert got.signed_with(subscription.secret)
    assert not got.signed_with("another secret")
    assert got.event_id == delivery.event_id == got.payload["id"]
    assert got.payload["task"]["status"] == "due"
    delivery.refresh_from_db()
    assert (delivery.state, delivery.attempts, delivery.last_status_code) == ("delivered", 1, 200)
    assert delivery.last_error == ""
    assert delivery_send(delivery_id=delivery.pk) is None  # delivered: never sent again


def test_a_receiver_that_fails_at_first_gets_it_on_a_retry_after_the_back_off(site, sent):
    with HookReceiver(fail_first=2) as receiver:
        subscription = subscribe(site, receiver.url)
        task_request(site)
        delivery = WebhookDelivery.objects.get()
        now = timezone.now()

        assert delivery_send(delivery_id=delivery.pk, now=now) is False
        delivery.refresh_from_db()
        assert delivery.next_attempt_at == now + timedelta(seconds=FIRST_RETRY_SECONDS)
        assert delivery_send(delivery_id=delivery.pk, now=now + timedelta(seconds=1)) is None

        later = now + timedelta(seconds=FIRST_RETRY_SECONDS)
        assert delivery_send(delivery_id=delivery.pk, now=later) is False
        delivery.refresh_from_db()
        assert delivery.next_attempt_at == later + timedelta(seconds=2 * FIRST_RETRY_SECONDS)

        assert delivery_send(delivery_id=delivery.pk, now=later + timedelta(seconds=4)) is True

    assert [each.answered for each in receiver.received] == [500, 500, 200]
    assert {each.event_id for each in receiver.received} == {delivery.event_id}
    assert all(each.signed_with(subscription.secret) for each in receiver.received)
    delivery.refresh_from_db()
    assert (delivery.state, delivery.attempts) == ("delivered", 3)


def test_it_gives_up_after_the_last_attempt(site, sent):
    subscribe(site, "http://127.0.0.1:9/hook")  # nothing listens on port 9
    task_request(site)
    delivery = WebhookDelivery.objects.get()
    at = timezone.now()
    for _ in range(MAX_ATTEMPTS):
        assert delivery_send(delivery_id=delivery.pk, now=at) is False
        at += timedelta(seconds=retry_delay(MAX_ATTEMPTS) + 1)
    delivery.refresh_from_db()
    assert (delivery.state, delivery.attempts) == ("failed", MAX_ATTEMPTS)
    assert delivery.last_error == "unreachable"


def test_back_off_doubles_up_to_an_hour():
    assert [retry_delay(n) for n in (1, 2, 3, 4)] == [2, 4, 8, 16]
    assert retry_delay(30) == 3600


def test_a_signature_covers_timestamp_and_body():
    signed = signature("s3cret", 1795420800, b'{"a":1}')
    assert signature_valid("s3cret", timestamp="1795420800", body=b'{"a":1}', signed=signed)
    assert not signature_valid("s3cret", timestamp="1795420801", body=b'{"a":1}', signed=signed)
    assert not signature_valid("s3cret", timestamp="1795420800", body=b'{"a":2}', signed=signed)
    assert not signature_valid("s3cret", timestamp="x", body=b'{"a":1}', signed=signed)


def test_the_page_lists_subscriptions_and_deliveries_with_their_status(site, operator, sent):
    with HookReceiver(fail_first=1) as receiver:
        subscribe(site, receiver.url, name="Pharmacy system")
        task_request(site)
        delivery_send(delivery_id=WebhookDelivery.objects.get().pk)
    client = Client()
    client.force_login(operator)

    page = client.get("/webhooks/").content.decode()

    assert "Pharmacy system" in page
    assert receiver.url in page
    assert "500 <span" in page
    assert "Answered with a status other than 2xx" in page


def test_the_page_is_for_operators_only(site, nurse):
    client = Client()
    client.force_login(nurse)
    assert client.get("/webhooks/").status_code == 403
