"""A Redis that accepts connections and never answers stalls no request (core/outbox.py).

Before, an operator's Pause took 10 s and another robot's heartbeat 9.7 s: the wake-up was
published inside the transaction holding the robot's row lock, with the Redis client's default
timeout and retry. Here gunicorn runs with REDIS_URL pointing at such a listener.
"""

import re
import statistics
import time

import pytest
import requests

from bench.stack import SilentRedis
from core.pubsub import PUBLISH_TIMEOUT
from tests import factories, servers
from tests.conftest import RobotHttp

# Far below the 5-10 s a stalled publish took, far above a heartbeat on a busy test machine.
PROMPT = 2.0


@pytest.fixture
def silent_redis():
    redis = SilentRedis()
    yield redis
    redis.close()


@pytest.fixture
def stalled_server(transactional_db, silent_redis):
    env = {"REDIS_URL": silent_redis.url}
    with servers.gunicorn(workers=2, env=env) as url:
        yield url


def timed(call):
    started = time.monotonic()
    response = call()
    return response, time.monotonic() - started


def logged_in(url: str, username: str) -> requests.Session:
    session = requests.Session()
    page = session.get(f"{url}/accounts/login/", timeout=30).text
    csrf = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page).group(1)
    form = {"username": username, "password": factories.PASSWORD, "csrfmiddlewaretoken": csrf}
    answer = session.post(f"{url}/accounts/login/", data=form, timeout=30)
    assert answer.url.rstrip("/") == url, answer.text[:300]
    return session


def test_it_answers_heartbeats_and_an_operators_pause_promptly_while_redis_stalls(
    stalled_server, site, operator, silent_redis
):
    r1, r2 = (
        RobotHttp(stalled_server, factories.robot_create(site, code)) for code in ("R1", "R2")
    )
    session = logged_in(stalled_server, operator.username)

    times = []
    for seq in range(1, 6):  # each changes what the pages show: a publish every time
        for robot in (r1, r2):
            body = factories.heartbeat_body(seq, state={"battery": 0.9 - seq / 100})
            response, took = timed(lambda robot=robot, body=body: robot.post(body))
            assert response.status_code == 200, response.text
            times.append(took)
    # A publish waited for in the request would cost each of these PUBLISH_TIMEOUT at least.
    assert statistics.median(times) < 0.9 * PUBLISH_TIMEOUT, times
    assert max(times) < PROMPT, times

    csrf = session.cookies["csrftoken"]
    pause, took = timed(
        lambda: session.post(
            f"{stalled_server}/robots/R1/action",
            data={"action": "pause", "csrfmiddlewaretoken": csrf},
            timeout=30,
        )
    )
    assert pause.status_code == 200, pause.text[:300]
    assert took < PROMPT, f"Pause took {took:.2f} s"
    reply, took = timed(lambda: r1.post(factories.heartbeat_body(10)))
    assert took < PROMPT, f"the paused robot's heartbeat took {took:.2f} s"
    assert [m["action"] for m in reply.json()["messages"] if m["type"] == "action"] == ["pause"]
    assert silent_redis.held, "the server never tried Redis: the test proves nothing"
