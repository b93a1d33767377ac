"""What every page's base template needs: where the websocket is, the user's roles, and the
open alerts (one query, and only when the page shows them)."""

from django.conf import settings

from core.access import is_member, is_operator
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
        # A lazy queryset: evaluated (once) only by a template that lists the alerts.
        "open_alerts": alerts_open() if member else (),
    }
