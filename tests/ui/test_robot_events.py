"""Live "robot" and "task" events: published after commit, and only when pages would change."""

import itertools
from datetime import datetime, timedelta

import pytest
from django.db import transaction

from robots.models import Waypoint
from robots.services import presence_sweep, robot_heartbeat_record, robot_lock
from scheduling.services import robot_action
from tests import factories
from tests.scheduling.conftest import Beater, request
from ui.live.publish import site_group

# 09:00:00 site time: 10-second refresh periods start at whole tens of seconds.
T0 = datetime.fromisoformat("2026-11-22T09:00:00+09:00")


@pytest.fixture
def sent(monkeypatch):
    """What ui.live.publish hands to the channel layer (after commit), in order."""
    sent = []
    monkeypatch.setattr(
        "ui.live.publish.group_send", lambda group, message: sent.append((group, message))
    )
    return sent


def of_kind(sent, kind: str) -> list[dict]:
    return [message["data"] for _group, message in sent if message.get("kind") == kind]


@pytest.fixture
def heartbeat(robot, django_capture_on_commit_callbacks):
    """Record a heartbeat's state at `now`, committed (its on-commit callbacks run)."""
    seqs = itertools.count(1)
    lab = Waypoint.objects.get(site=robot.site, code="1F-PHARM")

    def record(now: datetime, **state):
        state = {
            "status": "idle",
            "floor_id": lab.floor_id,
            "waypoint_id": lab.pk,
            "x": 10.0,
            "y": 10.0,
            "battery": 0.9,
            "load": 0,
            "plan_version": 0,
            "errors": [],
            **state,
        }
        with django_capture_on_commit_callbacks(execute=True), transaction.atomic():
            locked = robot_lock(robot.pk)
            robot_heartbeat_record(robot=locked, boot_id="b", seq=next(seqs), state=state, now=now)

    return record


def test_it_publishes_robot_state_only_after_commit(
    robot, site, sent, django_capture_on_commit_callbacks
):
    with django_capture_on_commit_callbacks() as callbacks:
        Beater(robot).beat(status="moving", battery=0.834, x=1.5, y=2.0, load=1)
        assert sent == []  # nothing before the heartbeat's transaction commits

    for callback in callbacks:
        callback()

    [(group, message)] = sent
    assert group == site_group(site.pk)
    assert message["type"] == "site.event"
    data = message["data"]
    assert message["kind"] == "robot"
    assert {key: data[key] for key in ("code", "presence", "status", "floor", "waypoint")} == {
        "code": "R1",
        "presence": "online",
        "status": "moving",
        "floor": "1F",
        "waypoint": "1F-DOCK-1",
    }
    assert (data["battery"], data["load"], data["capacity"], data["x"], data["y"]) == (
        83,
        1,
        4,
        1.5,
        2.0,
    )
    assert data["place"] == "Dock 1"
    assert data["last_seen_at"]


def test_it_publishes_a_task_event_only_after_commit(
    site, sent, django_capture_on_commit_callbacks
):
    with django_capture_on_commit_callbacks() as callbacks:
        task = request(site)
        assert sent == []

    for callback in callbacks:
        callback()

    [event] = of_kind(sent, "task")
    assert event["code"] == task.code
    assert (event["status"], event["status_label"], event["cause"]) == (
        "due",
        "Due, waiting for a robot",
        "request",
    )


def test_it_publishes_nothing_when_nothing_shown_changed(heartbeat, sent):
    heartbeat(T0)  # offline -> online: shown
    heartbeat(T0 + timedelta(seconds=1))  # the same
    heartbeat(T0 + timedelta(seconds=2), battery=0.904)  # still 90 %
    heartbeat(T0 + timedelta(seconds=3), x=10.001)  # a millimetre

    assert len(of_kind(sent, "robot")) == 1


@pytest.mark.parametrize(
    "change",
    [
        {"status": "moving"},
        {"battery": 0.89},
        {"x": 11.0},
        {"y": 9.5},
        {"load": 1},
        {"errors": ["bumper pressed"]},
        {"waypoint_id": None},
    ],
)
def test_it_publishes_each_change_pages_show(heartbeat, sent, change):
    heartbeat(T0)

    heartbeat(T0 + timedelta(seconds=1), **change)

    assert len(of_kind(sent, "robot")) == 2


def test_it_refreshes_last_seen_every_ten_seconds(heartbeat, sent):
    for second in range(25):
        heartbeat(T0 + timedelta(seconds=second))

    seen = [event["last_seen_at"] for event in of_kind(sent, "robot")]
    assert [datetime.fromisoformat(at).second for at in seen] == [0, 10, 20]


def test_it_publishes_presence_flips_of_the_sweep(
    heartbeat, sent, django_capture_on_commit_callbacks
):
    heartbeat(T0)

    with django_capture_on_commit_callbacks(execute=True):
        presence_sweep(now=T0 + timedelta(seconds=4))  # 3 intervals of 1 s: unreachable

    assert [event["presence"] for event in of_kind(sent, "robot")] == ["online", "unreachable"]


def test_it_publishes_an_operators_hold(robot, sent, django_capture_on_commit_callbacks):
    operator = factories.user_create("park", "operator")

    with django_capture_on_commit_callbacks(execute=True):
        robot_action(robot=robot, action="pause", by=operator)

    [event] = of_kind(sent, "robot")
    assert event["paused_by_operator"] is True
