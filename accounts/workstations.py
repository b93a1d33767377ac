"""Shared ward workstations: which workstation an account is, and who is ordering at it.

A person identifies at a workstation with their badge and PIN, or with their user name and own
password (the directory's, for a directory user). Both go through Django's authenticate(), so
django-axes throttles wrong PINs as it throttles wrong passwords at the login page, and each
failure is a user_login_failed signal like a failed sign-in. Nobody is signed in by it: the
workstation's own session stays, and the order is placed in the person's name.
"""

import logging

from axes.helpers import get_client_ip_address
from axes.utils import reset as axes_reset
from django.conf import settings
from django.contrib.auth import authenticate

from accounts.models import Workstation
from core.access import is_member
from robots.badges import badge_matches
from robots.membership import may_see_site
from robots.models import SiteMembership

logger = logging.getLogger(__name__)


def workstation_of(user) -> Workstation | None:
    """The workstation this account is, if it is one (read once per request)."""
    if not user.is_authenticated:
        return None
    if not hasattr(user, "_workstation"):
        found = Workstation.objects.filter(user=user).select_related("site", "unit").first()
        user._workstation = found
    return user._workstation


def badge_holder(*, workstation: Workstation, badge: str):
    """The user whose badge this is among the members of the workstation's site who have a
    badge and a PIN: those of its unit first. Each badge has its own salt (robots/badges.py), so
    each is hashed in turn; only the hashes are compared, and nothing of the badge is kept."""
    memberships = (
        SiteMembership.objects.filter(site=workstation.site, user__is_active=True)
        .exclude(badge_hash="")
        .exclude(user__account__pin_hash="")
        .filter(user__account__isnull=False)
        .select_related("user")
        .order_by("user_id")
    )
    ordered = sorted(memberships, key=lambda m: m.unit_id != workstation.unit_id)
    return next((m.user for m in ordered if badge_matches(badge, m.badge)), None)


def unknown_badge_name(workstation: Workstation) -> str:
    """Whom failed attempts with a badge nobody holds are counted against (django-axes needs a
    name): the workstation, in words no username can take (usernames have no spaces)."""
    return f"unknown badge at {workstation.user.get_username()}"


def person_identify(
    request, *, workstation: Workstation, badge="", pin="", username="", password=""
):
    """The active user who is ordering: by badge and PIN, else by user name and password; None
    when they do not match or that user is locked out (request.axes_locked_out is then set,
    and the lockout page answers)."""
    if badge:
        holder = badge_holder(workstation=workstation, badge=badge)
        name = holder.get_username() if holder is not None else unknown_badge_name(workstation)
        person = authenticate(request, username=name, pin_secret=pin, workstation=workstation)
    else:
        person = authenticate(request, username=username, password=password)
    if person is not None and settings.AXES_RESET_ON_SUCCESS:
        # As a successful sign-in does (AXES_RESET_ON_SUCCESS): earlier mistakes are forgiven.
        axes_reset(ip=get_client_ip_address(request), username=person.get_username())
    return person


def may_order_at(person, workstation: Workstation) -> bool:
    """A nurse or operator (or staff) of the workstation's site."""
    return is_member(person) and may_see_site(person, workstation.site_id)
