"""The deliveries page (the paper's Figure 4): the request form and the schedule table, a
task's history, and cancelling from the table.

A request goes through the API's own validation (TaskRequestSerializer) and service
(task_request), so a nurse's form and a hospital system's API call behave alike.
"""

from functools import wraps

from django.contrib import messages
from django.core.exceptions import PermissionDenied
from django.http import Http404
from django.shortcuts import get_object_or_404, redirect, render
from django.urls import reverse
from django.utils.translation import gettext as _
from django.views.decorators.http import require_POST

from accounts.workstations import workstation_of
from core.access import can_cancel, is_member, member_required
from fhir_r4.selectors import order_for_staff
from fhir_r4.services import order_read_record
from robots.membership import site_required
from robots.models import Site
from scheduling.deadlines import lateness_note
from scheduling.models import Task
from scheduling.selectors import (
    given_back_entries,
    history_in_words,
    station_options,
    stations_for_site,
    task_detail,
    task_disruption,
)
from scheduling.serializers import TaskRequestSerializer
from scheduling.services import (
    PinNotResendable,
    TaskNotCancellable,
    task_cancel,
    task_pin_resend,
    task_request,
)
from ui.forms import DeliveryRequestForm
from ui.live.parts import schedule_context, user_may_cancel
from ui.selectors import page_site, pin_for_requester


def workstations_to_their_page(view):
    """A shared workstation's account has a page of its own (ui/workstation.py): sent there
    from the pages a person uses, such as this one, where signing in lands."""

    @wraps(view)
    def guarded(request, *args, **kwargs):
        # A workstation has no role of its own (accounts.Workstation.clean): members are not
        # asked (no query more on their pages).
        if not is_member(request.user) and workstation_of(request.user) is not None:
            return redirect("workstation")
        return view(request, *args, **kwargs)

    return guarded


@workstations_to_their_page
@member_required
def deliveries(request):
    """GET: the form and the schedule. POST: request a delivery; on success back to the page
    (the new task in the table), else the form again with each error next to its field."""
    site, sites = page_site(request)
    stations = stations_for_site(site=site)
    form = DeliveryRequestForm(
        request.POST if request.method == "POST" else None,
        sites=sites,
        site=site,
        stations=stations,
    )
    if request.method == "POST":
        # The API checks what the form could read even if it could not read everything, so
        # every problem is shown at once (the form's own first: a time it cannot read).
        form_valid = form.is_valid()
        request_data = TaskRequestSerializer(data=form.api_data())
        if request_data.is_valid() and form_valid:
            task = task_request(requester=request.user, **request_data.validated_data)
            messages.success(request, f"Delivery {task.code} requested: {task.contents}.")
            request_warnings(request, task)
            return redirect(_deliveries_url(task.site))
        form.add_api_errors(request_data.errors)
    status = 400 if form.is_bound else 200
    context = {
        "page_site": site,
        "sites": sites,
        "form": form,
        "station_options": station_options(site=site),
        **schedule_context(request, site),
    }
    return render(request, "scheduling/deliveries.html", context, status=status)


def request_warnings(request, task) -> None:
    """What the requester must know of a delivery just requested: a secure one's PIN, and
    that it will be late."""
    if task.secure:
        messages.warning(
            request,
            f"PIN for {task.code}: {task.pin_plain}. Give it to the recipient: it opens the "
            "robot's compartment. You find it again on the delivery's page, and the receiving "
            "station's staff on their station page, until it is delivered.",
        )
    late = lateness_note(eta=task.eta, due_at=task.due_at)
    if late:
        messages.warning(request, f"{task.code} will be late: {late}.")


@member_required
def task_history(request, code: str):
    """Every transition of a task with its time and cause; ?partial=1 for the page's dialog."""
    task = task_detail(code=code)
    if task is None:
        raise Http404(f"no task {code!r}")
    site_required(request.user, task.site_id, f"task {code!r}")
    history = history_in_words(task)
    notice, on_hold = task_disruption(task, given_back_entries(task))
    order = order_for_staff(task)
    if order is not None:
        order_read_record(task=task, via="delivery page")
    context = {
        "page_site": task.site,
        "task": task,
        "history": history,
        "notice": notice,
        "on_hold": on_hold,
        "can_cancel": user_may_cancel(request.user, task),
        # A secure delivery's PIN, again, to whoever asked for it, until it is handed over.
        "pin": pin_for_requester(task, request.user),
        # Ordered by a hospital system (FHIR): its order and patient, by identifiers only.
        "order": order,
    }
    if request.GET.get("partial"):
        return render(request, "scheduling/_task_history.html", context)
    return render(request, "scheduling/task_history.html", context)


@require_POST
@member_required
def task_cancel_post(request, code: str):
    task = get_object_or_404(Task.objects.with_code(code).select_related("site"))
    site_required(request.user, task.site_id, f"task {code!r}")
    if not can_cancel(request.user, task):
        raise PermissionDenied("only operators may cancel other people's deliveries")
    try:
        task_cancel(task=task, by=request.user)
    except TaskNotCancellable as refused:
        messages.error(request, f"{task.code} could not be cancelled: {refused}.")
    else:
        messages.success(request, f"Delivery {task.code} cancelled.")
    return redirect(_deliveries_url(task.site))


@require_POST
@member_required
def task_pin_resend_post(request, code: str):
    """The requester of a secure delivery posts its PIN again to the receiving station's page."""
    task = get_object_or_404(Task.objects.with_code(code).select_related("site"))
    site_required(request.user, task.site_id, f"task {code!r}")
    try:
        task_pin_resend(task=task, user=request.user)
    except PinNotResendable as refused:
        messages.error(
            request,
            _("The PIN of %(code)s was not re-sent: %(why)s.")
            % {"code": task.code, "why": refused},
        )
    else:
        messages.success(
            request,
            _(
                "The PIN of %(code)s is shown again on the receiving station's page, to its "
                "unit's staff signed in there."
            )
            % {"code": task.code},
        )
    return redirect("task-history", task.code)


def _deliveries_url(site: Site) -> str:
    return f"{reverse('deliveries')}?site={site.code}"
