import pytest
import requests
from django.conf import settings
from django.contrib.auth import BACKEND_SESSION_KEY, HASH_SESSION_KEY, SESSION_KEY
from django.contrib.sessions.backends.db import SessionStore


class ApiHttp:
    """A hospital system (a staff user's API token) calling the live server over real HTTP."""

    def __init__(self, base_url: str, session: requests.Session):
        self.base_url = base_url
        self.session = session

    def get(self, path, **kwargs):
        return self.session.get(f"{self.base_url}{path}", timeout=30, **kwargs)

    def post(self, path, body=None, *, raw: bytes | None = None, **kwargs):
        url = f"{self.base_url}{path}"
        if raw is not None:
            headers = {"Content-Type": "application/json", **kwargs.pop("headers", {})}
            return self.session.post(url, data=raw, headers=headers, timeout=30, **kwargs)
        return self.session.post(url, json=body, timeout=30, **kwargs)


def logged_in_session(user) -> requests.Session:
    """A requests session carrying a session cookie for `user` (as after the login form)."""
    store = SessionStore()
    store[SESSION_KEY] = str(user.pk)
    store[BACKEND_SESSION_KEY] = "django.contrib.auth.backends.ModelBackend"
    store[HASH_SESSION_KEY] = user.get_session_auth_hash()
    store.create()
    session = requests.Session()
    session.cookies.set(settings.SESSION_COOKIE_NAME, store.session_key)
    return session


@pytest.fixture
def api_http(live_server, staff):
    session = requests.Session()
    session.headers["Authorization"] = f"Bearer {staff.api_token_plain}"
    return ApiHttp(live_server.url, session)


@pytest.fixture
def nurse_http(live_server, nurse):
    return ApiHttp(live_server.url, logged_in_session(nurse))
