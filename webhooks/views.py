"""The webhooks page: the subscriptions of the user's sites and their recent deliveries, each
with its answer's status and a fixed reason. Subscriptions are added and changed in the admin
(/admin/webhooks/subscription/)."""

from django.shortcuts import render

from core.access import operator_required
from robots.membership import member_site_ids
from webhooks.selectors import deliveries_recent, subscriptions_with_counts


@operator_required
def webhooks_page(request):
    site_ids = member_site_ids(request.user)
    context = {
        "subscriptions": subscriptions_with_counts(site_ids=site_ids),
        "deliveries": deliveries_recent(site_ids=site_ids),
    }
    return render(request, "webhooks/webhooks.html", context)
