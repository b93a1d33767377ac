"""A shared ward workstation's page, and a person's own workstation PIN.

The workstation stays signed in as itself (accounts.Workstation: a site and a unit). Each order
there is confirmed by the person placing it, with their badge and PIN or their user name and
password, and is requested in that person's name; the page then shows the next order's form,
still as the workstation. The badge, PIN and password are never sent back in a page nor logged.
"""

import logging

from django.contrib import messages
from django.contrib.auth.decorators import login_required
from django.core.exceptions import PermissionDenied, ValidationError
from django.shortcuts import redirect, render
from django.views.decorators.debug import sensitive_post_parameters

from accounts.services import account_pin_set
from accounts.workstations import may_order_at, person_identify, workstation_of
from core.access import member_required
from scheduling.selectors import station_options, stations_for_site
from scheduling.serializers import TaskRequestSerializer
from scheduling.services import task_request
from ui.deliveries import request_warnings, workstations_to_their_page
from ui.forms import DeliveryRequestForm, IdentifyForm, PinForm
from ui.selectors import tasks_by_pk

logger = logging.getLogger(__name__)

# The orders placed at this workstation, newest last, kept in its session for its list.
ORDERS_SESSION_KEY = "workstation_orders"
ORDERS_SHOWN = 10


@sensitive_post_parameters("badge", "pin", "password")
@login_required
def workstation_page(request):
    """GET: the order form and who confirms it. POST: the order, placed in the name of the
    person who identified; then back to an empty form."""
    workstation = workstation_of(request.user)
    if workstation is None:
        raise PermissionDenied("this account is not a shared workstation")
    site = workstation.site
    data = request.POST if request.method == "POST" else None
    form = DeliveryRequestForm(data, sites=[site], site=site, stations=stations_for_site(site=site))
    identify = IdentifyForm(data)
    if data is not None:
        form_valid = form.is_valid()
        # Always the workstation's own site, whatever the form says.
        request_data = TaskRequestSerializer(data={**form.api_data(), "site": site.code})
        if not (request_data.is_valid() and form_valid):
            form.add_api_errors(request_data.errors)
        elif identify.is_valid():
            person = _person(request, workstation, identify)
            if person is not None:
                task = task_request(requester=person, **request_data.validated_data)
                _remember(request, task)
                logger.info(
                    "delivery %s requested by %s at workstation %s",
                    task.code,
                    person.get_username(),
                    workstation.user.get_username(),
                )
                name = person.get_full_name() or person.get_username()
                messages.success(
                    request, f"Delivery {task.code} requested by {name}: {task.contents}."
                )
                request_warnings(request, task)
                return redirect("workstation")
    context = {
        "workstation": workstation,
        "page_site_name": str(site),
        "form": form,
        "identify": identify,
        "sites": [site],
        "station_options": station_options(site=site),
        "orders": tasks_by_pk(request.session.get(ORDERS_SESSION_KEY, []), site=site),
    }
    status = 400 if data is not None else 200
    return render(request, "accounts/workstation.html", context, status=status)


def _person(request, workstation, identify: IdentifyForm):
    """The person who confirmed the order, or None with the reason added to the form."""
    fields = identify.cleaned_data
    person = person_identify(request, workstation=workstation, **fields)
    if person is None:
        if fields["badge"]:
            identify.add_error("pin", "This badge and PIN do not match: scan and type them again.")
        else:
            identify.add_error("password", "This user name and password do not match.")
        return None
    if not may_order_at(person, workstation):
        name = person.get_full_name() or person.get_username()
        identify.add_error(None, f"{name} may not order deliveries at {workstation.site}.")
        return None
    return person


def _remember(request, task) -> None:
    orders = [*request.session.get(ORDERS_SESSION_KEY, []), task.pk]
    request.session[ORDERS_SESSION_KEY] = orders[-ORDERS_SHOWN:]


@sensitive_post_parameters("pin", "pin_again")
@workstations_to_their_page
@member_required
def pin_page(request):
    """The signed-in person sets the PIN they confirm orders with at shared workstations."""
    form = PinForm(request.POST if request.method == "POST" else None)
    if request.method == "POST" and form.is_valid():
        try:
            account_pin_set(user=request.user, pin=form.cleaned_data["pin"])
        except ValidationError as invalid:
            form.add_error("pin", invalid.message_dict["pin"])
        else:
            messages.success(request, "Your workstation PIN is set.")
            return redirect("deliveries")
    status = 400 if form.is_bound else 200
    return render(request, "accounts/pin.html", {"form": form}, status=status)
