"""Behind the proxy, lock-outs count by the client's real address: one machine's wrong passwords
lock that machine out, not the user everywhere, and a client cannot pose as another address
by sending X-Forwarded-For itself. Through real nginx (hospital_delivery/proxy.py) and
gunicorn; the clients connect from different loopback addresses (127.0.0.0/8 is all local)."""

import re
import shutil

import pytest
import requests
from django.conf import settings
from django.test import RequestFactory, override_settings
from requests.adapters import HTTPAdapter

from core.clientaddress import client_address
from tests import factories, servers

NURSES_PC = "127.0.0.3"
ATTACKER = "127.0.0.2"


class FromAddress(HTTPAdapter):
    """Connections from one local source address, as from another machine."""

    def __init__(self, source: str):
        self.source = source
        super().__init__()

    def init_poolmanager(self, *args, **kwargs):
        kwargs["source_address"] = (self.source, 0)
        super().init_poolmanager(*args, **kwargs)


def session_from(source: str) -> requests.Session:
    session = requests.Session()
    session.mount("http://", FromAddress(source))
    return session


def login(session, base_url: str, username: str, password: str, **headers):
    page = session.get(f"{base_url}/accounts/login/", timeout=30)
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page.text).group(1)
    form = {"username": username, "password": password, "csrfmiddlewaretoken": token}
    return session.post(
        f"{base_url}/accounts/login/",
        data=form,
        headers={"Referer": f"{base_url}/accounts/login/", **headers},
        allow_redirects=False,
        timeout=30,
    )


@pytest.fixture(scope="module")
def proxy(django_db_setup):
    if shutil.which("nginx") is None:
        pytest.skip("./scripts/test.sh installs nginx")
    with (
        servers.gunicorn(workers=2) as web,
        servers.daphne() as ws,
        servers.nginx(web_url=web, ws_url=ws.url) as url,
    ):
        yield url


@pytest.mark.slow
def test_wrong_passwords_from_one_machine_do_not_lock_the_user_out_elsewhere(
    proxy, transactional_db
):
    factories.user_create("kim", "nurse")
    attacker = session_from(ATTACKER)
    for _ in range(settings.AXES_FAILURE_LIMIT):
        # Posing as the nurse's machine changes nothing: nginx appends what it saw.
        login(attacker, proxy, "kim", "wrong", **{"X-Forwarded-For": NURSES_PC})

    locked = login(attacker, proxy, "kim", factories.PASSWORD)
    nurse = login(session_from(NURSES_PC), proxy, "kim", factories.PASSWORD)

    assert locked.status_code == 429
    assert "Too many wrong passwords" in locked.text
    assert nurse.status_code == 302, nurse.text[:300]
    assert settings.SESSION_COOKIE_NAME in nurse.cookies


def meta_request(remote: str, forwarded: str | None = None):
    headers = {"HTTP_X_FORWARDED_FOR": forwarded} if forwarded is not None else {}
    return RequestFactory().get("/", REMOTE_ADDR=remote, **headers)


@pytest.mark.parametrize(
    ("count", "remote", "forwarded", "client"),
    [
        (1, "127.0.0.1", "10.1.2.3", "10.1.2.3"),
        (1, "127.0.0.1", "6.6.6.6, 10.1.2.3", "10.1.2.3"),  # the client's own entry ignored
        (1, "127.0.0.1", None, "127.0.0.1"),  # not through the proxy
        (1, "127.0.0.1", "not-an-address", "127.0.0.1"),
        (2, "127.0.0.1", "6.6.6.6, 10.1.2.3, 10.9.9.9", "10.1.2.3"),
        (2, "127.0.0.1", "10.9.9.9", "127.0.0.1"),
        (0, "10.1.2.3", "6.6.6.6", "10.1.2.3"),  # no proxy: the header means nothing
    ],
)
def test_the_client_is_the_entry_the_outermost_trusted_proxy_saw(count, remote, forwarded, client):
    with override_settings(TRUSTED_PROXY_COUNT=count):
        assert client_address(meta_request(remote, forwarded)) == client
