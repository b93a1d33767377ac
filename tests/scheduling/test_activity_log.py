"""The activity log (hospital_delivery/activity.py): a line per delivery's status change and per
alert, at INFO whatever LOG_LEVEL, once committed; never the PIN of a secure delivery."""

import logging

import pytest

from robots.alerts import alert_raise
from robots.models import Robot
from robots.models.alerts import AlertKind
from scheduling.services import task_allocate
from tests.scheduling.conftest import request, robot_ready


@pytest.fixture
def activity(caplog):
    caplog.set_level(logging.INFO, logger="activity")
    return caplog


def lines(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "activity"]


@pytest.mark.django_db
def test_it_logs_each_status_change_once_committed(
    activity, robot, site, django_capture_on_commit_callbacks
):
    Robot.objects.filter(pk=robot.pk).update(compartments=[{"code": "A", "lockable": True}])
    robot_ready(robot)
    with django_capture_on_commit_callbacks(execute=True):
        task = request(site, secure=True)
        task_allocate(task_id=task.pk)
        assert lines(activity) == []  # nothing before the commit

    assert lines(activity) == [
        f"delivery {task.code}: new -> due (Requested)",
        f"delivery {task.code}: due -> assigned by R1 (Allocated)",
    ]
    assert task.pin_plain not in activity.text


@pytest.mark.django_db
def test_it_logs_an_alert_raised(activity, site, django_capture_on_commit_callbacks):
    with django_capture_on_commit_callbacks(execute=True):
        alert_raise(site_id=site.pk, kind=AlertKind.ROBOT_ERROR, key="k", message="R1 is stuck")

    assert lines(activity) == [f"alert {AlertKind.ROBOT_ERROR.label}: R1 is stuck"]
