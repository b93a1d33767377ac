"""Batteries: low robots are sent to charge, and no robot is given a route it cannot finish with
the site's reserve left (real PostgreSQL, heartbeats through the real view)."""

from robots.models import Robot, Site
from scheduling.models import Task
from scheduling.services import due_sweep, task_allocate
from scheduling.services.allocation import NO_BATTERY
from tests.scheduling.conftest import Beater, event, plans, request, status


def dock_stops(reply: dict) -> list[dict]:
    return [stop for plan in plans(reply) for stop in plan["stops"] if stop["action"] == "dock"]


def test_a_low_robot_with_nothing_on_board_is_sent_to_charge_and_back_to_work_when_charged(
    r1, site
):
    beater = Beater(r1)

    reply = beater.beat(battery=0.15)  # below the site's threshold (0.2)

    assert dock_stops(reply) == [{"action": "dock", "waypoint": "1F-DOCK-1", "charge": True}]
    r1.refresh_from_db()
    assert r1.sent_to_charge
    waiting = request(site)
    assert not task_allocate(task_id=waiting.pk)
    beater.ack_all(reply, battery=0.5, status="charging")  # above the threshold, not charged
    assert due_sweep() == 0

    beater.beat(battery=0.8, status="charging")  # the site's battery_charged

    r1.refresh_from_db()
    assert not r1.sent_to_charge
    assert due_sweep() == 1
    waiting.refresh_from_db()
    assert waiting.robot == r1


def test_the_pages_hear_when_a_robot_is_sent_to_charge_and_when_it_is_charged(
    r1, site, monkeypatch, django_capture_on_commit_callbacks
):
    sent = []
    monkeypatch.setattr("ui.live.publish.group_send", lambda group, message: sent.append(message))
    beater = Beater(r1)

    def robot_events(**state):
        sent.clear()
        with django_capture_on_commit_callbacks(execute=True):
            beater.beat(**state)
        return [m["data"]["sent_to_charge"] for m in sent if m["kind"] == "robot"]

    assert robot_events(battery=0.9) == [False]
    assert robot_events(battery=0.15)[-1] is True
    assert robot_events(battery=0.5, status="charging")[-1:] in ([], [True])
    assert robot_events(battery=0.8, status="charging")[-1] is False


def test_a_low_robot_gives_back_what_it_has_not_picked_up(r1, r2, site):
    task = request(site)
    assert task_allocate(task_id=task.pk)
    task.refresh_from_db()
    holder = r1 if task.robot_id == r1.pk else r2

    reply = Beater(holder).beat(battery=0.1)

    assert dock_stops(reply)[0]["charge"] is True
    task.refresh_from_db()
    assert (task.status, task.robot) == ("due", None)
    assert "sent to charge" in task.history.last().note


def test_a_low_robot_with_items_on_board_delivers_them_first(r1, site):
    task = request(site)
    task_allocate(task_id=task.pk)
    beater = Beater(r1)
    beater.beat(events=[event("loaded", task.code, 0)], waypoint="1F-PHARM")

    reply = beater.beat(battery=0.1, waypoint="1F-PHARM")

    assert not dock_stops(reply)
    r1.refresh_from_db()
    assert not r1.sent_to_charge
    assert status(task) == "picked_up"
    assert Task.objects.get(pk=task.pk).robot == r1


def test_a_robot_is_not_given_a_route_it_cannot_finish_with_the_reserve_left(r1, site):
    Site.objects.filter(pk=site.pk).update(battery_per_metre=0.002)  # 20 % per 100 m
    Robot.objects.filter(pk=r1.pk).update(battery=0.3)  # above the threshold (0.2)
    # Dock -> pharmacy -> ward 3 -> dock is 140 m and 2 rides: 0.28 + 0.002, leaving under 0.1.
    task = request(site, dropoffs=("3F-WARD",))

    assert not task_allocate(task_id=task.pk)

    task.refresh_from_db()
    assert (task.status, task.waiting_reason) == ("due", NO_BATTERY)
    Robot.objects.filter(pk=r1.pk).update(battery=0.9)
    assert task_allocate(task_id=task.pk)


def test_a_robot_short_of_battery_leaves_the_task_to_one_that_is_not(r1, r2, site):
    Site.objects.filter(pk=site.pk).update(battery_per_metre=0.002)
    Robot.objects.filter(pk=r1.pk).update(battery=0.3)

    task = request(site, dropoffs=("3F-WARD",))

    assert task_allocate(task_id=task.pk)
    task.refresh_from_db()
    assert task.robot == r2
