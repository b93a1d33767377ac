"""Reads for the webhooks page."""

from django.db.models import Count, Q

from webhooks.choices import DeliveryState
from webhooks.models import Subscription, WebhookDelivery

RECENT = 100


def subscriptions_with_counts() -> list[Subscription]:
    counts = {
        f"n_{state}": Count("deliveries", filter=Q(deliveries__state=state))
        for state in DeliveryState.values
    }
    return list(Subscription.objects.select_related("site").annotate(**counts))


def deliveries_recent(*, limit: int = RECENT) -> list[WebhookDelivery]:
    rows = WebhookDelivery.objects.select_related("subscription").order_by("-id")
    return list(rows[:limit])
