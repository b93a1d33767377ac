"""Failed sign-ins throttled per client address, whatever the username, before any password is
hashed.

django-axes locks one username at one address (settings.AXES_LOCKOUT_PARAMETERS), so it
cannot be used to lock a nurse out from elsewhere; but an address trying ever new usernames,
known or not, never trips it, and each attempt costs a password hash (PBKDF2, a million
iterations: about half a CPU-second) on the web workers the robots' heartbeats use too. Here a
counter per address (one row, core.clientaddress) stops that: after LOGIN_ADDRESS_FAILURE_LIMIT
failures within LOGIN_LOCKOUT_MINUTES, the address's sign-in posts are answered with the
lock-out page (429) until the window ends, before the view runs, so without a hash. Within the
allowance an unknown username still costs one hash, as Django does on purpose, so that the
answer's time does not tell which usernames exist.
"""

from datetime import timedelta

from django.conf import settings
from django.db import transaction
from django.db.models import F
from django.shortcuts import render
from django.urls import reverse
from django.utils import timezone

from core.clientaddress import client_address
from hospital_delivery.models import SignInThrottle


def _window() -> timedelta:
    return settings.AXES_COOLOFF_TIME


def address_throttled(address: str, *, now) -> bool:
    """One indexed read: whether `address` used up its failures in the current window."""
    return SignInThrottle.objects.filter(
        address=address,
        window_started_at__gt=now - _window(),
        failures__gte=settings.LOGIN_ADDRESS_FAILURE_LIMIT,
    ).exists()


@transaction.atomic
def failure_record(*, address: str, now) -> None:
    """Count one failed sign-in from `address`; a window that has ended starts again."""
    started = now - _window()
    row, created = SignInThrottle.objects.select_for_update().get_or_create(
        address=address, defaults={"window_started_at": now, "failures": 1}
    )
    if created:
        SignInThrottle.objects.filter(window_started_at__lte=started).delete()
    elif row.window_started_at <= started:
        row.window_started_at, row.failures = now, 1
        row.save(update_fields=["window_started_at", "failures"])
    else:
        row.failures = F("failures") + 1
        row.save(update_fields=["failures"])


def on_login_failed(sender, credentials=None, request=None, **kwargs) -> None:
    """django.contrib.auth's user_login_failed: every failure counts, known username or not."""
    if request is not None:
        failure_record(address=client_address(request), now=timezone.now())


class SignInThrottleMiddleware:
    """Answers a sign-in post from a throttled address with the lock-out page, before the
    login view (and so the password hasher) runs."""

    def __init__(self, get_response):
        self.get_response = get_response
        self._paths = None

    def __call__(self, request):
        if self._is_sign_in(request) and address_throttled(
            client_address(request), now=timezone.now()
        ):
            return locked_out(request)
        return self.get_response(request)

    def _is_sign_in(self, request) -> bool:
        return request.method == "POST" and request.path_info in self._login_paths()

    def _login_paths(self) -> frozenset[str]:
        if self._paths is None:
            # A shared workstation's orders are confirmed with a badge and PIN or a password
            # (ui/workstation.py): their failures count here too, and an unknown badge costs a
            # hash per badge of the site.
            paths = {reverse("login"), reverse("admin:login"), reverse("workstation")}
            self._paths = frozenset(paths)
        return self._paths


def locked_out(request):
    """The same page and status as django-axes' lock-out."""
    context = {"cooloff_timedelta": _window(), "by_address": True}
    return render(
        request,
        settings.AXES_LOCKOUT_TEMPLATE,
        context,
        status=settings.AXES_HTTP_RESPONSE_CODE,
    )
