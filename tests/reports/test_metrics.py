"""/metrics: protected, and its figures follow what happens (heartbeats, robots, tasks, leases,
boards, sweeps)."""

from datetime import timedelta

import pytest
from django.test import Client, override_settings
from django.utils import timezone

from boards.services import board_post
from reports.metrics import exposition
from robots.models import Robot
from scheduling.models import Task
from tests import factories
from tests.reports.metrics import value
from tests.scheduling.conftest import request as task_request

pytestmark = pytest.mark.django_db

TOKEN = "scrape-token-for-tests"


def scrape(now=None) -> str:
    return exposition(now=now or timezone.now()).decode()


@override_settings(METRICS_TOKEN=TOKEN)
def test_it_answers_a_scraper_with_the_token():
    response = Client().get("/metrics", HTTP_AUTHORIZATION=f"Bearer {TOKEN}")
    assert response.status_code == 200
    assert response["Content-Type"].startswith("text/plain")
    assert "# TYPE hd_heartbeats_total counter" in response.content.decode()


@override_settings(METRICS_TOKEN=TOKEN)
@pytest.mark.parametrize("header", [None, "Bearer wrong", f"Basic {TOKEN}", "Bearer "])
def test_it_refuses_a_scraper_without_the_right_token(header):
    headers = {"HTTP_AUTHORIZATION": header} if header else {}
    response = Client().get("/metrics", **headers)
    assert response.status_code == 401
    assert response.json()["error"] == "unauthorized"
    assert "Authorization" in response.json()["detail"]


@override_settings(METRICS_TOKEN="")
def test_an_empty_token_setting_lets_no_scraper_in():
    assert Client().get("/metrics", HTTP_AUTHORIZATION="Bearer ").status_code == 401


def test_operators_read_it_with_their_login_and_nurses_do_not(operator, nurse):
    operators, nurses = Client(), Client()
    operators.force_login(operator)
    nurses.force_login(nurse)
    assert operators.get("/metrics").status_code == 200
    refused = nurses.get("/metrics")
    assert refused.status_code == 403
    assert refused.json() == {
        "error": "forbidden",
        "detail": {"user": ["only operators and staff may read the metrics"]},
    }


def test_it_counts_and_times_heartbeats(robot):
    client = Client()
    url = f"/api/v1/robots/{robot.code}/heartbeat"
    before = scrape()

    for seq in (1, 2):
        client.post(
            url,
            factories.heartbeat_body(seq),
            content_type="application/json",
            HTTP_AUTHORIZATION=f"Bearer {robot.token}",
        )
    client.post(url, {}, content_type="application/json", HTTP_AUTHORIZATION="Bearer nope")

    after = scrape()
    assert (
        value(after, "hd_heartbeats_total", code="200")
        - value(before, "hd_heartbeats_total", code="200")
        == 2
    )
    assert (
        value(after, "hd_heartbeats_total", code="401")
        - value(before, "hd_heartbeats_total", code="401")
        == 1
    )
    assert (
        value(after, "hd_heartbeat_seconds_count") - value(before, "hd_heartbeat_seconds_count")
        == 3
    )


def test_it_shows_robots_by_presence_and_status_and_who_is_offline_with_load(site):
    now = timezone.now()
    factories.robot_create(site, "R1")
    carrying = factories.robot_create(site, "R2")
    Robot.objects.filter(pk=carrying.pk).update(presence="unreachable", status="moving", load=2)

    text = scrape(now)

    assert value(text, "hd_robots", site=site.code, presence="offline", status="unknown") == 1
    assert value(text, "hd_robots", site=site.code, presence="unreachable", status="moving") == 1
    assert value(text, "hd_robot_items_on_board", robot="R2", presence="unreachable") == 2
    assert value(text, "hd_robots_not_online_with_load", site=site.code) == 1


def test_it_shows_tasks_by_status_and_the_ones_past_due(site):
    now = timezone.now()
    task_request(site)  # due, just requested: due by the site's routine due time
    late = task_request(site, priority="urgent")
    Task.objects.filter(pk=late.pk).update(due_at=now - timedelta(minutes=1))
    routine = task_request(site)
    Task.objects.filter(pk=routine.pk).update(due_at=now + timedelta(minutes=1))
    # From before deadlines existed: no due time, so never past due.
    old = task_request(site)
    Task.objects.filter(pk=old.pk).update(due_at=None, requested_time=now - timedelta(days=1))

    text = scrape(now)

    assert value(text, "hd_tasks", site=site.code, status="due") == 4
    assert value(text, "hd_tasks_past_due", site=site.code, priority="urgent") == 1
    # Each task's own due time (due_at), not a due time per priority.
    assert value(text, "hd_tasks_past_due", site=site.code, priority="routine") == 0
    later = scrape(now + timedelta(minutes=2))
    assert value(later, "hd_tasks_past_due", site=site.code, priority="routine") == 1


def test_it_shows_pending_board_messages_and_lease_queues(site):
    now = timezone.now()
    r1, r2 = factories.robot_create(site, "R1"), factories.robot_create(site, "R2")
    board_post(robot=r1, type="action", body={"action": "pause"})
    elevator = site.resources.get(code="ELEV")
    factories.lease_acquire(robot=r1, resource=elevator, request_id="q-1", to_floor="3F", now=now)
    factories.lease_acquire(robot=r2, resource=elevator, request_id="q-2", to_floor="3F", now=now)

    text = scrape(now + timedelta(seconds=30))

    assert value(text, "hd_board_messages_pending", site=site.code) >= 3  # pause, grant, queued
    assert value(text, "hd_lease_queue_length", resource="ELEV") == 1
    assert value(text, "hd_lease_queue_oldest_wait_seconds", resource="ELEV") == pytest.approx(30)
    assert value(text, "hd_lease_wait_seconds_count", kind="elevator") >= 1


def test_sweep_lag_is_how_long_a_passed_deadline_has_waited(site):
    now = timezone.now()
    robot = factories.robot_create(site, "R1")
    assert value(scrape(now), "hd_sweep_lag_seconds", sweep="presence") == 0
    Robot.objects.filter(pk=robot.pk).update(
        presence="online",
        last_seen_at=now - timedelta(seconds=20),
        unreachable_at=now - timedelta(seconds=12),
        offline_at=now + timedelta(minutes=5),
    )

    text = scrape(now)

    assert value(text, "hd_sweep_lag_seconds", sweep="presence") == pytest.approx(12)
    assert value(text, "hd_sweep_lag_seconds", sweep="ack_timeout") == 0
    assert value(text, "hd_redis_up") == 1
    assert "hd_celery_queue_length" in text
