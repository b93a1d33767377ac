"""When a delivery is due: its requested time plus its priority's due time.

The due times come from settings.DELIVERY_DUE_MINUTES ({"urgent": 15, "normal": 60, "*": 60};
"*" for any priority not named), so priorities added later need no code here.
"""

from datetime import timedelta

from django.conf import settings
from django.db.models import Q

OTHERS = "*"


def due_minutes(priority: str) -> int:
    minutes = settings.DELIVERY_DUE_MINUTES
    return minutes.get(priority, minutes[OTHERS])


def due_delta(priority: str) -> timedelta:
    return timedelta(minutes=due_minutes(priority))


def requested_before_due(now) -> Q:
    """Tasks whose due time (requested time + their priority's due time) is before `now`."""
    named = [p for p in settings.DELIVERY_DUE_MINUTES if p != OTHERS]
    others = Q(requested_time__lt=now - timedelta(minutes=settings.DELIVERY_DUE_MINUTES[OTHERS]))
    past = Q(~Q(priority__in=named), others)
    for priority in named:
        past |= Q(priority=priority, requested_time__lt=now - due_delta(priority))
    return past
