"""Stuck robots (scheduling/services/stuck.py): moving without progress past the site's
stuck_timeout raises exactly one alert and makes its deliveries' ETAs later; a robot waiting
its turn for a lift does not; progress clears it."""

from datetime import timedelta

import time_machine
from django.utils import timezone

from resources.choices import LeaseState
from robots.models import Alert, AlertKind, Resource
from scheduling.models import TaskTransition
from scheduling.services.stuck import stuck_sweep
from tests import factories
from tests.factories import lease_acquire
from tests.scheduling.conftest import Beater, request

TIMEOUT = timedelta(seconds=600)  # the tiny site's stuck_timeout: the default


def beat_at(beater: Beater, at, **state) -> dict:
    with time_machine.travel(at, tick=False):
        return beater.beat(**state)


def stuck_alerts():
    return Alert.objects.filter(kind=AlertKind.ROBOT_STUCK)


def test_it_raises_one_alert_for_a_robot_moving_in_place_and_makes_its_etas_later(site, r1):
    task = request(site, allocate_now=True)
    beater = Beater(r1)
    start = timezone.now()
    beat_at(beater, start, status="moving", waypoint="1F-HALL", x=10.0, y=0.2)
    beat_at(beater, start + TIMEOUT / 2, status="moving", waypoint="1F-HALL", x=10.3, y=0.1)
    assert stuck_sweep(now=start + TIMEOUT - timedelta(seconds=1)) == 0
    task.refresh_from_db()
    eta = task.eta

    assert stuck_sweep(now=start + TIMEOUT) == 1

    assert stuck_sweep(now=start + 2 * TIMEOUT) == 0  # one alert per time it is stuck
    [alert] = stuck_alerts()
    assert alert.robot == r1
    assert alert.task == task.code
    assert "1F near 1F-HALL (x 10.3, y 0.1)" in alert.message
    assert task.code in alert.message
    task.refresh_from_db()
    assert task.eta == eta + TIMEOUT
    note = TaskTransition.objects.filter(task=task).latest("pk").note
    assert note == "R1 is stuck at 1F near 1F-HALL (x 10.3, y 0.1): this delivery will be late"

    # Progress clears it: stuck again later is a new time (the alert, once acknowledged).
    beat_at(beater, start + 2 * TIMEOUT, status="moving", waypoint="1F-PHARM", x=10.0, y=10.0)
    r1.refresh_from_db()
    assert r1.stuck_since is None
    assert stuck_sweep(now=start + 2 * TIMEOUT + TIMEOUT / 2) == 0


def test_a_robot_waiting_its_turn_for_a_lift_is_not_stuck(site, r1, r2):
    lift = Resource.objects.get(site=site, code="ELEV")
    lease_acquire(robot=r2, resource=lift, request_id="q-first", to_floor="2F")
    queued = lease_acquire(robot=r1, resource=lift, request_id="q-next", to_floor="2F")
    assert queued.state == LeaseState.QUEUED
    beater = Beater(r1)
    start = timezone.now()
    beat_at(beater, start, status="moving", waypoint="1F-ELEV-WAIT", x=20.0, y=0.0)
    beat_at(beater, start + TIMEOUT, status="moving", waypoint="1F-ELEV-WAIT", x=20.0, y=0.0)

    assert stuck_sweep(now=start + 3 * TIMEOUT) == 0
    assert not stuck_alerts().exists()


def test_a_robot_that_is_not_moving_is_not_stuck(site, r1):
    beater = Beater(r1)
    start = timezone.now()
    beat_at(beater, start, status="waiting_unload", waypoint="1F-PHARM")
    assert stuck_sweep(now=start + 3 * TIMEOUT) == 0
    factories.site_create(site="other", stuck_timeout=60)  # another site's timeout changes nothing
    assert stuck_sweep(now=start + 3 * TIMEOUT) == 0
