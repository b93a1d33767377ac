"""Resources out of service: an elevator under maintenance, a door that reports a fault.

A resource out of service is granted to nobody (resources.leases._free): robots that ask for
it queue, and those already queued stay there, held rather than failed, until it is back.
Every robot with a live lease on it is told (`resource_out_of_service`, then
`resource_in_service`); routers avoid it where another way exists (robots/router.py, keyed
by the site's availability_version); operators are alerted; and the receivers of
resources.hooks.availability_changed (the scheduler) plan affected routes again.

Robots inside, or granted and on their way in, keep their leases: a car with a robot in it
is not emptied by a flag, and the operator sees them on the fleet page.
"""

from datetime import datetime

from django.db import transaction
from django.db.models import F
from django.utils import timezone
from django.utils.translation import gettext_noop

from core import changes
from core.said import Said
from resources.hooks import availability_changed
from resources.leases import (
    lease_grants_take_back,
    out_of_service_tell,
    resource_live_leases,
    resource_lock,
    resource_serve,
)
from robots.alerts import alert_raise, alerts_close
from robots.models import AlertKind, Resource, Site

REASON_MAX = 200
OUT_OF_SERVICE = gettext_noop(
    "%(code)s is out of service: %(reason)s. Robots go another way where there is one; "
    "the others wait in its queue until it is back."
)
OUT_OF_SERVICE_BY = gettext_noop(
    "%(code)s is out of service by %(user)s: %(reason)s. Robots go another way where there is "
    "one; the others wait in its queue until it is back."
)


@transaction.atomic
def resource_take_out_of_service(
    *, resource: Resource, reason: str, actor=None, now: datetime | None = None
) -> bool:
    """Take `resource` out of service; False (nothing changed) if it already was."""
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    if not resource.in_service:
        return False
    resource.out_of_service_since = now
    resource.out_of_service_reason = reason[:REASON_MAX]
    resource.save(update_fields=["out_of_service_since", "out_of_service_reason"])
    _changed(resource, now=now)
    said = {"code": resource.code, "reason": resource.out_of_service_reason}
    if actor is not None:
        message = Said(OUT_OF_SERVICE_BY, **said, user=actor.get_username())
    else:
        message = Said(OUT_OF_SERVICE, **said)
    alert_raise(
        site_id=resource.site_id,
        kind=AlertKind.RESOURCE_OUT_OF_SERVICE,
        key=_alert_key(resource),
        message=message,
        resource=resource,
    )
    return True


@transaction.atomic
def resource_return_to_service(*, resource: Resource, actor=None, now: datetime | None = None):
    """Return `resource` to service and grant its queue in order; False if it was in service."""
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    if resource.in_service:
        return False
    resource.out_of_service_since = None
    resource.out_of_service_reason = ""
    resource.save(update_fields=["out_of_service_since", "out_of_service_reason"])
    _changed(resource, now=now)
    alerts_close(key=_alert_key(resource), by=actor, at=now)
    resource_serve(resource=resource, now=now)
    return True


@transaction.atomic
def resource_priority_start(
    *, resource: Resource, reason: str, actor=None, now: datetime | None = None
) -> bool:
    """Hold an elevator for an emergency team: its holder finishes its ride, a grant not
    used yet is taken back, nobody is granted it and routes avoid it until
    resource_priority_end; False (nothing changed) if it already was held."""
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    if resource.in_priority:
        return False
    resource.priority_since, resource.priority_reason = now, reason[:REASON_MAX]
    resource.save(update_fields=["priority_since", "priority_reason"])
    lease_grants_take_back(resource=resource)
    _changed(resource, now=now)
    who = Said(gettext_noop(" by %(user)s"), user=actor.get_username()) if actor else ""
    alert_raise(
        site_id=resource.site_id,
        kind=AlertKind.LIFT_PRIORITY,
        key=_priority_key(resource),
        message=Said(
            gettext_noop(
                "%(code)s is held for an emergency team%(who)s: %(reason)s. The robot inside "
                "finishes its ride; no robot is granted it until it is released; robots go "
                "another way where there is one, the others wait."
            ),
            code=resource.code,
            who=who,
            reason=resource.priority_reason,
        ),
        resource=resource,
    )
    return True


@transaction.atomic
def resource_priority_end(*, resource: Resource, actor=None, now: datetime | None = None) -> bool:
    """Release an elevator held for an emergency team: its queue is granted in order; False if
    it was not held."""
    now = now or timezone.now()
    resource = resource_lock(resource.pk)
    if not resource.in_priority:
        return False
    resource.priority_since, resource.priority_reason = None, ""
    resource.save(update_fields=["priority_since", "priority_reason"])
    _changed(resource, now=now)
    alerts_close(key=_priority_key(resource), by=actor, at=now)
    resource_serve(resource=resource, now=now)
    return True


def _priority_key(resource: Resource) -> str:
    return f"lift-priority:{resource.pk}"


def _changed(resource: Resource, *, now: datetime) -> None:
    """Tell every robot with a live lease, make routers see it, then the receivers above."""
    for lease in resource_live_leases(resource):
        out_of_service_tell(lease.robot, resource)
    # The routers' cache key (robots/mapcache.py): every process re-reads the map's service
    # state on the next robot row it reads. F() so concurrent bumps never lose one.
    site = Site.objects.filter(pk=resource.site_id)
    site.update(availability_version=F("availability_version") + 1)
    resource.site.refresh_from_db(fields=["availability_version"])
    changes.changed(kind=changes.RESOURCE, site_id=resource.site_id, subject=resource)
    availability_changed(resource=resource, now=now)


def _alert_key(resource: Resource) -> str:
    return f"resource-out-of-service:{resource.pk}"
