"""Login throttling (django-axes) on the login page and the admin's, over real HTTP."""

import re

import pytest
import requests
from axes.models import AccessAttempt
from django.conf import settings
from django.contrib.auth.hashers import PBKDF2PasswordHasher
from django.core.management import call_command

from tests import factories


def login(base_url: str, path: str, username: str, password: str, session=None):
    """Post the login form at `path` as a browser does (CSRF cookie and token first)."""
    session = session or requests.Session()
    page = session.get(f"{base_url}{path}", timeout=30)
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page.text).group(1)
    form = {"username": username, "password": password, "csrfmiddlewaretoken": token}
    response = session.post(
        f"{base_url}{path}",
        data=form,
        headers={"Referer": f"{base_url}{path}"},
        allow_redirects=False,
        timeout=30,
    )
    return session, response


def logged_in(session) -> bool:
    return settings.SESSION_COOKIE_NAME in session.cookies


@pytest.mark.parametrize("path", ["/accounts/login/", "/admin/login/"])
def test_it_locks_out_after_too_many_wrong_passwords(live_server, path):
    factories.user_create("operator", "operator", is_staff=True)
    for _ in range(settings.AXES_FAILURE_LIMIT - 1):
        _, response = login(live_server.url, path, "operator", "wrong")
        assert response.status_code == 200  # the form again, with its error
    _, response = login(live_server.url, path, "operator", "wrong")
    assert response.status_code == 429

    session, response = login(live_server.url, path, "operator", factories.PASSWORD)

    assert response.status_code == 429
    assert "Too many wrong passwords" in response.text
    assert "ask an administrator" in response.text
    assert not logged_in(session)


def test_a_few_wrong_passwords_do_not_lock_out(live_server):
    factories.user_create("kim", "nurse")
    for _ in range(settings.AXES_FAILURE_LIMIT - 1):
        login(live_server.url, "/accounts/login/", "kim", "wrong")

    session, response = login(live_server.url, "/accounts/login/", "kim", factories.PASSWORD)

    assert response.status_code == 302
    assert logged_in(session)


def test_an_administrator_unlocks_with_a_command(live_server):
    factories.user_create("kim", "nurse")
    for _ in range(settings.AXES_FAILURE_LIMIT):
        login(live_server.url, "/accounts/login/", "kim", "wrong")
    assert AccessAttempt.objects.filter(username="kim").exists()

    call_command("axes_reset_username", "kim")

    session, response = login(live_server.url, "/accounts/login/", "kim", factories.PASSWORD)
    assert response.status_code == 302
    assert logged_in(session)


def test_an_administrator_sees_and_deletes_lockouts_in_the_admin(live_server):
    factories.user_create("kim", "nurse")
    factories.user_create("root", is_staff=True, is_superuser=True)
    for _ in range(settings.AXES_FAILURE_LIMIT):
        login(live_server.url, "/accounts/login/", "kim", "wrong")
    admin, _ = login(live_server.url, "/admin/login/", "root", factories.PASSWORD)
    attempt = AccessAttempt.objects.get(username="kim")

    listing = admin.get(f"{live_server.url}/admin/axes/accessattempt/", timeout=30)
    assert listing.status_code == 200
    assert "kim" in listing.text
    page = admin.get(f"{live_server.url}/admin/axes/accessattempt/{attempt.pk}/delete/", timeout=30)
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page.text).group(1)
    admin.post(
        f"{live_server.url}/admin/axes/accessattempt/{attempt.pk}/delete/",
        data={"post": "yes", "csrfmiddlewaretoken": token},
        headers={"Referer": live_server.url},
        timeout=30,
    )

    assert not AccessAttempt.objects.filter(username="kim").exists()
    session, response = login(live_server.url, "/accounts/login/", "kim", factories.PASSWORD)
    assert response.status_code == 302


@pytest.fixture
def hashes(monkeypatch):
    """How many times the password hasher ran (checking a password, or the stand-in check
    Django runs for an unknown username)."""
    calls = []
    encode = PBKDF2PasswordHasher.encode

    def counted(self, *args, **kwargs):
        calls.append(1)
        return encode(self, *args, **kwargs)

    monkeypatch.setattr(PBKDF2PasswordHasher, "encode", counted)
    return calls


def test_an_address_trying_many_usernames_is_throttled_before_any_hash(
    live_server, settings, hashes
):
    settings.LOGIN_ADDRESS_FAILURE_LIMIT = 4
    factories.user_create("kim", "nurse")
    hashes.clear()  # its password's
    for n in range(4):  # never the same username twice: django-axes alone never trips
        _, response = login(live_server.url, "/accounts/login/", f"nobody{n}", "wrong")
        assert response.status_code == 200
    assert len(hashes) == 4  # an unknown username costs a hash too, so timing tells nothing
    hashes.clear()

    refused = [
        login(live_server.url, path, username, password)[1]
        for path, username, password in [
            ("/accounts/login/", "nobody9", "wrong"),
            ("/admin/login/", "admin", "wrong"),
            ("/accounts/login/", "kim", factories.PASSWORD),
        ]
    ]

    assert [response.status_code for response in refused] == [429, 429, 429]
    assert "tried from this computer" in refused[-1].text
    assert hashes == []  # none of them ran the hasher
    assert settings.SESSION_COOKIE_NAME not in refused[-1].cookies
