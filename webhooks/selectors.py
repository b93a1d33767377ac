"""Reads for the webhooks page, narrowed to the sites a user may see."""

from django.db.models import Count, Q

from webhooks.choices import DeliveryState
from webhooks.models import Subscription, WebhookDelivery

RECENT = 100


def subscriptions_with_counts(*, site_ids: frozenset[int] | None) -> list[Subscription]:
    """The subscriptions of `site_ids` (None: every site) with their deliveries by state."""
    counts = {
        f"n_{state}": Count("deliveries", filter=Q(deliveries__state=state))
        for state in DeliveryState.values
    }
    rows = Subscription.objects.select_related("site")
    if site_ids is not None:
        rows = rows.filter(site_id__in=site_ids)
    return list(rows.annotate(**counts))


def deliveries_recent(
    *, site_ids: frozenset[int] | None, limit: int = RECENT
) -> list[WebhookDelivery]:
    rows = WebhookDelivery.objects.select_related("subscription").order_by("-id")
    if site_ids is not None:
        rows = rows.filter(subscription__site_id__in=site_ids)
    return list(rows[:limit])
