"""GET /healthz and the sweeps' watchdog: which part is down, and the pages' alert."""

import time

import pytest
import requests
from django.conf import settings

from core import watchdog as healthz
from core.redisclient import redis_client
from tests.security.conftest import ApiHttp, logged_in_session

SWEEPS = sorted(entry["task"] for entry in settings.CELERY_BEAT_SCHEDULE.values())


def all_sweeps_ran(seconds_ago: float = 0.0, *, except_=()):
    for name in SWEEPS:
        if name not in except_:
            healthz.sweep_record(name, at=time.time() - seconds_ago)


@pytest.fixture(autouse=True)
def fresh_sweep_records():
    """Each test starts with no sweep on record (this run's own Redis keys)."""
    keys = [healthz._key(name) for name in SWEEPS]
    redis_client().delete(*keys)
    yield
    redis_client().delete(*keys)


def test_it_answers_200_when_everything_runs(live_server):
    all_sweeps_ran()

    response = requests.get(f"{live_server.url}/healthz", timeout=30)

    assert response.status_code == 200
    body = response.json()
    assert body["status"] == "ok"
    assert (body["database"], body["redis"]) == ("ok", "ok")
    assert set(body["sweeps"]) == set(SWEEPS)
    assert all(sweep["ok"] and sweep["last_run"] for sweep in body["sweeps"].values())
    assert settings.SECRET_KEY not in response.text
    assert "redis://" not in response.text


def test_it_answers_503_naming_a_sweep_that_stopped(live_server):
    all_sweeps_ran(except_=["scheduling.tasks.ack_timeout_sweep"])
    healthz.sweep_record("scheduling.tasks.ack_timeout_sweep", at=time.time() - 60)

    response = requests.get(f"{live_server.url}/healthz", timeout=30)

    assert response.status_code == 503
    body = response.json()
    assert body["down"] == ["sweeps"]
    assert body["sweeps"]["scheduling.tasks.ack_timeout_sweep"]["ok"] is False
    assert body["sweeps"]["robots.tasks.presence_sweep"]["ok"] is True


def test_it_answers_503_when_redis_is_unreachable(live_server, monkeypatch):
    monkeypatch.setattr(settings, "REDIS_URL", "redis://127.0.0.1:1/0")
    redis_client.cache_clear()
    try:
        response = requests.get(f"{live_server.url}/healthz", timeout=30)
    finally:
        monkeypatch.undo()
        redis_client.cache_clear()

    assert response.status_code == 503
    assert response.json()["redis"] == "down"
    assert response.json()["database"] == "ok"


def test_pages_alert_when_the_sweeps_have_not_run(live_server, nurse, site):
    page = ApiHttp(live_server.url, logged_in_session(nurse))

    all_sweeps_ran(seconds_ago=600)
    assert "Background sweeps are not running" in page.get("/").text

    all_sweeps_ran()
    assert "Background sweeps are not running" not in page.get("/").text


def test_a_sweep_run_by_the_worker_is_recorded(db):
    from robots.tasks import presence_sweep

    presence_sweep.apply()  # runs it as a worker does, signals included (task_success)

    assert healthz.sweeps_status()["robots.tasks.presence_sweep"]["ok"] is True
