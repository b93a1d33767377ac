"""What every page's base template needs: where the websocket is, the user's roles, and the
open alerts (one query, and only when the page shows them)."""

from django.conf import settings

from core.access import is_auditor, is_member, is_operator
from core.watchdog import sweeps_overdue
from robots.membership import member_site_ids
from robots.selectors import alerts_open


def pages(request) -> dict:
    user = getattr(request, "user", None)
    member = user is not None and is_member(user)
    return {
        "websocket_url": settings.WEBSOCKET_URL,
        "websocket_port": settings.WEBSOCKET_PORT,
        "site_time_zone": settings.TIME_ZONE,
        "user_is_member": member,
        "user_is_operator": member and is_operator(user),
        "user_is_auditor": user is not None and is_auditor(user),
        # A lazy queryset: evaluated (once) only by a template that lists the alerts.
        "open_alerts": _alerts_of(user) if member else (),
        # Called (one Redis read) only by a page that shows it: base.html, for members.
        "sweeps_overdue": sweeps_overdue if member else (),
        # The login page's "Sign in with ..." button (OpenID Connect, accounts/oidc.py).
        "sso_provider_name": settings.OIDC_PROVIDER_NAME if settings.OIDC_ISSUER else "",
    }


def _alerts_of(user):
    """Open alerts of the user's sites (a lazy queryset)."""
    ids = member_site_ids(user)
    return alerts_open() if ids is None else alerts_open().filter(site_id__in=ids)
