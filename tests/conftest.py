import math
import os
import uuid

import pytest
import requests
from django.conf import settings
from django.test import override_settings

from robots import selectors
from tests import factories, servers


class RobotHttp:
    """A robot speaking protocol v1 to the live server over real HTTP."""

    def __init__(self, base_url: str, robot):
        self.url = f"{base_url}/api/v1/robots/{robot.code}/heartbeat"
        self.robot = robot
        self.session = requests.Session()

    def post(self, body=None, *, token=None, raw: bytes | None = None, headers=None):
        headers = {"Content-Type": "application/json", **(headers or {})}
        token = self.robot.token if token is None else token
        if token:
            headers["Authorization"] = f"Bearer {token}"
        if raw is None:
            return self.session.post(self.url, json=body, headers=headers, timeout=30)
        return self.session.post(self.url, data=raw, headers=headers, timeout=30)

    def heartbeat(self, seq=1, **fields):
        response = self.post(factories.heartbeat_body(seq, **fields))
        assert response.status_code == 200, response.text
        return response.json()


@pytest.fixture(scope="session", autouse=True)
def outbox_in_line():
    """In this process, pushes and Celery messages are sent at once, so a test reads what was
    sent when its callbacks have run; servers started as subprocesses use the outbox thread
    (tests/resources/test_redis_stalled.py)."""
    settings.OUTBOX_THREAD = False


@pytest.fixture(scope="session", autouse=True)
def passwords_hashed_quickly():
    """Passwords and workstation PINs hashed with few iterations (tests/hashers.py): what the
    tests check is who signs in, not what a hash costs."""
    quick = "tests.hashers.QuickPBKDF2PasswordHasher"
    # In its place: two hashers of one algorithm's name, and Django would check with the last.
    django_pbkdf2 = "django.contrib.auth.hashers.PBKDF2PasswordHasher"
    others = [name for name in settings.PASSWORD_HASHERS if name != django_pbkdf2]
    with override_settings(PASSWORD_HASHERS=[quick, *others]):
        yield


@pytest.fixture(scope="session", autouse=True)
def channels_prefix():
    """Pub/sub channels ignore Redis database numbers: keep this run's apart from any other."""
    prefix = f"hdtest-{uuid.uuid4().hex[:8]}"
    settings.CHANNEL_LAYERS["default"]["CONFIG"]["prefix"] = prefix
    os.environ["CHANNELS_PREFIX"] = prefix  # for servers started as subprocesses
    return prefix


@pytest.fixture
def site(db):
    return factories.site_create()


@pytest.fixture
def robot(site):
    return factories.robot_create(site, "R1")


@pytest.fixture
def robot_http(live_server, robot):
    return RobotHttp(live_server.url, robot)


@pytest.fixture
def fleet_counted_once(monkeypatch):
    """For tests that count a heartbeat's queries: the fleet is counted at most every
    COUNT_SECONDS (robots.selectors.robots_heartbeating), and on a loaded machine the heartbeat
    asserted on came more than that after the first and counted one query more.
    Counted at most once, as on a machine that keeps up."""
    monkeypatch.setattr(selectors, "COUNT_SECONDS", math.inf)


@pytest.fixture
def nurse(db):
    return factories.user_create("kim", "nurse", first_name="Kim")


@pytest.fixture
def operator(db):
    return factories.user_create("park", "operator")


@pytest.fixture
def staff(db):
    return factories.staff_create()


@pytest.fixture(scope="session")
def gunicorn_url(django_db_setup, django_db_blocker):
    """gunicorn with 2 sync workers on the test database, as run in production."""
    with servers.gunicorn(workers=2) as url:
        yield url


@pytest.fixture
def robot_gunicorn(gunicorn_url, transactional_db, robot):
    return RobotHttp(gunicorn_url, robot)
