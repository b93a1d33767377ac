"""Routes planned again when a resource goes out of or back into service
(resources/availability.py, through resources.hooks.availability_changed).

The hook runs with the resource row locked, and robot rows are always locked before resource
rows, so the plans are not touched there: a Celery task does it once that transaction has
committed, one robot at a time under its own lock. A robot whose best route is unchanged gets
no new plan; one with no other way keeps its route and waits in the resource's queue.
"""

import logging
from datetime import datetime

from django.db import transaction
from django.utils import timezone

from core.outbox import send_soon
from robots.services import robot_lock
from scheduling.models import RobotPlan
from scheduling.services.plans import robot_replan_if_changed

logger = logging.getLogger(__name__)


def reroute_enqueue(*, site_id: int, resource: str) -> None:
    """Ask a Celery worker to re-plan the site's robots once this transaction commits."""
    send = lambda: _send(site_id, resource)  # noqa: E731
    transaction.on_commit(lambda: send_soon(send, what=f"re-routing around {resource}"))


def _send(site_id: int, resource: str) -> None:
    from scheduling.tasks import site_reroute  # the tasks module imports the services

    site_reroute.delay(site_id, resource)


def site_reroute(*, site_id: int, now: datetime | None = None) -> list[str]:
    """Post a new plan to each robot of the site whose best route has changed; returns their
    codes."""
    now = now or timezone.now()
    with_plans = RobotPlan.objects.filter(robot__site_id=site_id).values_list("robot_id", flat=True)
    changed = []
    for robot_id in with_plans.order_by("robot_id"):
        with transaction.atomic():
            robot = robot_lock(robot_id)
            if robot_replan_if_changed(robot=robot, now=now) is not None:
                changed.append(robot.code)
    if changed:
        logger.info("re-routed %s", ", ".join(changed))
    return changed
