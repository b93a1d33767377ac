"""Reads about leases: for the pages (who holds and who waits for each resource, and how long
the next request would wait)."""

from dataclasses import dataclass
from datetime import datetime

from resources.choices import LIVE_LEASE_STATES
from resources.leases import resource_wait_estimate
from resources.models import Lease
from robots.mapcache import site_map
from robots.models import Resource, Site


@dataclass(frozen=True)
class QueuedLease:
    robot: str
    state: str
    state_label: str
    position: int | None  # 1 = next in line; None for holders
    lease: str = ""  # its public id ("L-12"), for an operator's force-release


def resource_queues(*, site: Site) -> dict[str, list[QueuedLease]]:
    """Every resource's holders, then its queue in order, by resource code (one query)."""
    queues: dict[str, list[QueuedLease]] = {code: [] for code in site_map(site).resources}
    leases = (
        Lease.objects.live()
        .filter(resource__site=site)
        .with_queue_position()
        .in_queue_order()
        .select_related("robot", "resource")
    )
    for lease in leases:
        queues.setdefault(lease.resource.code, []).append(
            QueuedLease(
                robot=lease.robot.code,
                state=lease.state,
                state_label=lease.get_state_display(),
                position=lease.queue_position,
                lease=lease.public_id,
            )
        )
    return queues


def resource_waits(*, site: Site, now: datetime) -> dict[str, float]:
    """Seconds a request arriving now would wait, by resource code, for the resources someone
    holds or waits for (an idle resource has no wait): two queries per such resource."""
    busy = Resource.objects.filter(site=site, leases__state__in=LIVE_LEASE_STATES).distinct()
    return {
        resource.code: resource_wait_estimate(resource=resource, now=now)
        for resource in busy.select_related("site")
    }
