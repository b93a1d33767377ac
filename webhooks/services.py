"""Webhook deliveries: created with the change they tell of, sent until answered, at least once.

    task status change ──(same transaction)──▶ WebhookDelivery rows, one per subscription
        ──(after commit)──▶ Celery: delivery_send ──▶ POST, signed
        failure ──▶ next attempt after 2, 4, 8 ... s (at most an hour), up to MAX_ATTEMPTS
    send_sweep (Celery beat) re-sends whatever is due, should a Celery message be lost.

An attempt claims its row with a conditional UPDATE (pushing next_attempt_at on by CLAIM), so a
retry message and the sweep never send the same delivery at once.
"""

import json
import logging
from datetime import datetime, timedelta

from django.db import transaction
from django.utils import timezone

from core import changes, memo
from fhir_r4.representation import task_resource
from fhir_r4.selectors import task_for_webhook
from scheduling.models import TaskTransition
from webhooks.choices import TASK_STATUS_CHANGED, AttemptFailure, DeliveryState, PayloadFormat
from webhooks.models import Subscription, WebhookDelivery
from webhooks.signing import EVENT_ID_HEADER, SIGNATURE_HEADER, TIMESTAMP_HEADER, signature
from webhooks.targets import TargetRefused, target_check, target_post

logger = logging.getLogger(__name__)

FIRST_RETRY_SECONDS = 2
LONGEST_RETRY_SECONDS = 3600
MAX_ATTEMPTS = 15  # about seven hours of trying
TIMEOUT_SECONDS = 5
CLAIM = timedelta(seconds=TIMEOUT_SECONDS * 4)
SWEEP_BATCH = 500


def deliveries_for_change(*, kind: str, site_id: int, subject, **_) -> list[int]:
    """Store one delivery per interested subscription for a task's status change; returns
    their ids. Runs inside the transaction that made the change: one query when nobody
    subscribes, one per heartbeat or allocation batch (core.memo) however many tasks move."""
    if kind != changes.TASK or subject.old == subject.new:
        return []
    active = memo.once(("webhooks.active", site_id), lambda: _active(site_id))
    wanted = [s for s in active if s.wants(subject.new)]
    if not wanted:
        return []
    payload = task_event_payload(subject)
    formats = {subscription.payload_format for subscription in wanted}
    fhir = fhir_task_payload(subject) if PayloadFormat.FHIR in formats else None
    rows = [
        WebhookDelivery(
            subscription=subscription,
            event_id=payload["id"],
            event=TASK_STATUS_CHANGED,
            payload=(
                fhir
                if subscription.payload_format == PayloadFormat.FHIR
                else {**payload, "site": subscription.site.code}
            ),
            next_attempt_at=subject.at,
        )
        for subscription in wanted
    ]
    return [row.pk for row in WebhookDelivery.objects.bulk_create(rows)]


def _active(site_id: int) -> list[Subscription]:
    """The site's active subscriptions: every status change of every task asks."""
    subscriptions = Subscription.objects.filter(site_id=site_id, active=True)
    return list(subscriptions.select_related("site").order_by("pk"))


def task_event_payload(entry: TaskTransition) -> dict:
    """What other systems receive of one status change (docs/integrators/webhooks.md)."""
    task = entry.task
    robot = entry.robot or task.robot
    return {
        "id": f"task-transition-{entry.pk}",
        "type": TASK_STATUS_CHANGED,
        "occurred_at": entry.at.isoformat(),
        "task": {
            "code": task.code,
            "status": entry.new,
            "previous_status": entry.old or None,
            "priority": task.priority,
            "sender": task.sender,
            "receiver": task.receiver,
            "contents": task.contents,
            "requested_time": task.requested_time.isoformat(),
            "robot": robot.code if robot else None,
        },
        "cause": entry.cause,
        "note": entry.note,
    }


def fhir_task_payload(entry: TaskTransition) -> dict:
    """The FHIR Task of the changed delivery as it is now, its history written so far
    included (docs/integrators/fhir.md, "Webhooks")."""
    return task_resource(task_for_webhook(entry.task_id))


def delivery_body(delivery: WebhookDelivery) -> bytes:
    """The same bytes on every attempt (the signature covers them)."""
    return json.dumps(delivery.payload, sort_keys=True, separators=(",", ":")).encode()


def delivery_send(*, delivery_id: int, now: datetime | None = None) -> bool | None:
    """Attempt one delivery if it is due: True if answered 2xx, False if it failed, None if
    it was not due (delivered, given up, or claimed by another attempt)."""
    now = now or timezone.now()
    claimed = WebhookDelivery.objects.due(now).filter(pk=delivery_id)
    if not claimed.update(next_attempt_at=now + CLAIM):
        return None
    delivery = WebhookDelivery.objects.select_related("subscription").get(pk=delivery_id)
    status, failure = _post(delivery, now)
    return _attempt_record(delivery, now=now, status=status, failure=failure)


def delivery_attempt(*, delivery_id: int) -> float | None:
    """delivery_send now; the seconds until the next attempt if this one failed and the
    delivery is not given up, else None."""
    if delivery_send(delivery_id=delivery_id) is not False:
        return None
    pending = WebhookDelivery.objects.filter(pk=delivery_id, state=DeliveryState.PENDING)
    attempts = pending.values_list("attempts", flat=True).first()
    return retry_delay(attempts) if attempts else None


def _post(delivery: WebhookDelivery, now: datetime) -> tuple[int | None, str]:
    """The answer's status (None if none came) and why the attempt failed ("" if it did not).
    The URL is checked again first: its host may resolve elsewhere since it was saved."""
    body = delivery_body(delivery)
    timestamp = int(now.timestamp())
    fhir = delivery.subscription.payload_format == PayloadFormat.FHIR
    headers = {
        "Content-Type": "application/fhir+json" if fhir else "application/json",
        "User-Agent": "hospital-delivery-webhooks/1",
        EVENT_ID_HEADER: delivery.event_id,
        TIMESTAMP_HEADER: str(timestamp),
        SIGNATURE_HEADER: signature(delivery.subscription.secret, timestamp, body),
    }
    try:
        target = target_check(delivery.subscription.url)
        status = target_post(target, body=body, headers=headers, timeout=TIMEOUT_SECONDS)
    except TargetRefused as failed:
        return None, failed.reason
    if 200 <= status < 300:
        return status, ""
    if 300 <= status < 400:
        return status, AttemptFailure.REDIRECT
    return status, AttemptFailure.NOT_2XX


def _attempt_record(delivery, *, now, status: int | None, failure: str) -> bool:
    delivery.attempts += 1
    delivery.last_attempt_at = now
    delivery.last_status_code = status
    delivery.last_error = failure
    fields = ["attempts", "last_attempt_at", "last_status_code", "last_error"]
    delivered = not failure
    if delivered:
        delivery.state, delivery.delivered_at = DeliveryState.DELIVERED, now
        fields += ["state", "delivered_at"]
    elif delivery.attempts >= MAX_ATTEMPTS:
        delivery.state = DeliveryState.FAILED
        fields.append("state")
        logger.warning("webhook %s gave up after %d attempts", delivery, delivery.attempts)
    else:
        delivery.next_attempt_at = now + timedelta(seconds=retry_delay(delivery.attempts))
        fields.append("next_attempt_at")
    delivery.save(update_fields=fields)
    return delivered


def retry_delay(attempts: int) -> float:
    """Seconds before the next attempt after `attempts` failed ones: 2, 4, 8, ... 3600."""
    return min(FIRST_RETRY_SECONDS * 2 ** (attempts - 1), LONGEST_RETRY_SECONDS)


def deliveries_due(*, now: datetime | None = None) -> list[int]:
    """Ids of deliveries whose attempt is due, oldest first (for the sweep)."""
    due = WebhookDelivery.objects.due(now or timezone.now()).order_by("next_attempt_at", "pk")
    return list(due.values_list("pk", flat=True)[:SWEEP_BATCH])


def send_after_commit(delivery_ids: list[int], enqueue) -> None:
    """Hand the new deliveries to `enqueue` (a Celery send) once the change commits."""
    if delivery_ids:
        transaction.on_commit(lambda: enqueue(delivery_ids), robust=True)
