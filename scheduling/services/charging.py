"""Batteries: a robot low on battery and with nothing on board is sent to charge at its dock,
and takes tasks again once charged; a route it cannot finish with the site's reserve left is
not given to it (scheduling.services.allocation).

Energy by the site: battery_per_metre driven and battery_per_ride in an elevator (1 = a full
battery), and battery_reserve, what a robot must still have back at its dock after a route.
"""

import logging
from collections.abc import Sequence
from datetime import datetime
from itertools import pairwise

from django.utils.translation import gettext_noop

from core.said import Said
from robots.mapcache import router_for
from robots.models import Robot, Site
from robots.selectors import robot_dock
from robots.services import robot_publish
from scheduling.allocator import Stop
from scheduling.choices import ROUTE_STATUSES
from scheduling.models import Task
from scheduling.services.plans import plan_dock_post
from scheduling.services.presence import robot_tasks_give_back

logger = logging.getLogger(__name__)


def route_energy(*, site: Site, start: str, stops: Sequence[Stop], dock: str) -> float:
    """The battery a robot uses from `start` through `stops` and back to `dock`."""
    router = router_for(site)
    places = [start, *(stop.place for stop in stops), dock]
    legs = [router.leg(a, b) for a, b in pairwise(places) if a != b]
    return sum(
        leg.metres * site.battery_per_metre + leg.rides * site.battery_per_ride for leg in legs
    )


def robot_can_finish(*, robot: Robot, start: str, stops: Sequence[Stop]) -> bool:
    """Whether the robot can do `stops` and get back to its dock with the site's reserve left
    (a robot that never reported its battery is not held back here)."""
    if robot.battery is None:
        return True
    use = route_energy(site=robot.site, start=start, stops=stops, dock=robot_dock(robot))
    return robot.battery - use >= robot.site.battery_reserve


def robot_battery_check(*, robot: Robot, now: datetime) -> bool:
    """On each fresh heartbeat (robot row locked): send the robot to charge when it is below
    the site's battery threshold with nothing on board (giving back the tasks it has not picked
    up), and let it take tasks again once charged. True if it was just sent to charge.

    Costs no query unless the battery is low or the robot is charging."""
    site, battery = robot.site, robot.battery
    if battery is None:
        return False
    if robot.sent_to_charge:
        if battery >= site.battery_charged:
            _sent_to_charge(robot, False)
            logger.info("%s is charged (%.0f %%): takes tasks again", robot.code, 100 * battery)
        return False
    if battery >= site.battery_threshold or _has_load(robot):
        return False
    _sent_to_charge(robot, True)  # first: a plan posted from here on is a charging one
    logger.info("%s is low (%.0f %%): sent to charge", robot.code, 100 * battery)
    note = Said(gettext_noop("given back: %(robot)s sent to charge"), robot=robot.code)
    if not robot_tasks_give_back(robot=robot, at=now, note=note):
        plan_dock_post(robot=robot, now=now)
    return True


def _sent_to_charge(robot: Robot, sent: bool) -> None:
    """Store it and show it: the fleet page marks a robot sent to charge, live."""
    robot.sent_to_charge = sent
    robot.save(update_fields=["sent_to_charge"])
    robot_publish(robot=robot)


def _has_load(robot: Robot) -> bool:
    """Items on board: some stop of one of its tasks on the way is done."""
    on_route = Task.objects.filter(robot=robot, status__in=ROUTE_STATUSES)
    return on_route.filter(stops__done_at__isnull=False).exists()
