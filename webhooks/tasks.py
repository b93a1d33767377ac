"""Celery tasks: take ids (or nothing), call one service. A lost message costs only time: the
sweep sends whatever is due."""

from celery import shared_task
from django.utils import timezone

from webhooks import services


@shared_task
def send_delivery(delivery_id: int) -> None:
    """One attempt; if it failed and is not given up, the next one after the back-off."""
    retry_in = services.delivery_attempt(delivery_id=delivery_id)
    if retry_in is not None:
        send_delivery.apply_async((delivery_id,), countdown=retry_in)


@shared_task
def send_sweep() -> None:
    for delivery_id in services.deliveries_due(now=timezone.now()):
        send_delivery.delay(delivery_id)


def enqueue(delivery_ids: list[int]) -> None:
    for delivery_id in delivery_ids:
        send_delivery.delay(delivery_id)
