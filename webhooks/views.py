"""The webhooks page: every subscription and the recent deliveries with their answers.
Subscriptions are added and changed in the admin (/admin/webhooks/subscription/)."""

from django.shortcuts import render

from core.access import operator_required
from webhooks.selectors import deliveries_recent, subscriptions_with_counts


@operator_required
def webhooks_page(request):
    context = {
        "subscriptions": subscriptions_with_counts(),
        "deliveries": deliveries_recent(),
    }
    return render(request, "webhooks/webhooks.html", context)
