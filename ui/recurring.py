"""Periodic requests on a page: nurses see and stop their own, operators everyone's."""

from dataclasses import dataclass

from django.contrib import messages
from django.core.exceptions import PermissionDenied
from django.shortcuts import get_object_or_404, redirect, render
from django.urls import reverse
from django.views.decorators.http import require_POST

from core.access import is_operator, member_required
from robots.membership import site_required
from scheduling.models import RecurringRequest
from scheduling.selectors import recurring_for, repeat_in_words
from scheduling.services import recurring_stop
from ui.selectors import page_site


@dataclass(frozen=True)
class Series:
    recurring: RecurringRequest
    when: str  # in words


@member_required
def recurring_list(request):
    site, sites = page_site(request)
    everyone = is_operator(request.user)
    series = recurring_for(site=site, user=request.user, everyone=everyone)
    context = {
        "page_site": site,
        "sites": sites,
        "everyone": everyone,
        "series": [Series(each, repeat_in_words(each.repeat)) for each in series],
    }
    return render(request, "scheduling/recurring.html", context)


@require_POST
@member_required
def recurring_stop_post(request, pk: int):
    recurring = get_object_or_404(RecurringRequest.objects.select_related("site"), pk=pk)
    site_required(request.user, recurring.site_id, "such periodic request")
    if not (is_operator(request.user) or recurring.requester_id == request.user.pk):
        raise PermissionDenied("only operators may stop other people's periodic requests")
    cancelled = recurring_stop(recurring=recurring, by=request.user)
    if cancelled is None:
        messages.info(request, "That periodic request had already been stopped.")
    else:
        upcoming = f"; {cancelled} upcoming cancelled" if cancelled else ""
        messages.success(request, f"Stopped: {recurring.contents}{upcoming}.")
    return redirect(f"{reverse('recurring')}?site={recurring.site.code}")
