"""A page's live socket follows its user's access: it closes when the user is deactivated, is
taken out of their group or off the site, or signs out, told by the process that made the
change (here the test process) to daphne's through Redis; and an open socket checks again on
its own, which finds an expired session (SESSION_IDLE_MINUTES)."""

import pytest
from asgiref.sync import async_to_sync
from channels.db import database_sync_to_async
from channels.testing import WebsocketCommunicator
from django.conf import settings
from django.contrib.auth.models import Group
from django.contrib.sessions.models import Session
from django.test import Client
from django.utils import timezone
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from hospital_delivery.asgi import application
from robots.models import SiteMembership
from tests import factories, servers

pytestmark = pytest.mark.django_db(transaction=True)

ORIGIN = "http://127.0.0.1:8000"  # a page served by gunicorn, another port


@pytest.fixture(scope="module")
def daphne_url(django_db_setup, django_db_blocker):
    # The periodic check (60 s by default) is far off: a close within the tests' deadline
    # can only come from the message the change sent.
    with servers.daphne() as server:
        yield server.url


def signed_in(user) -> Client:
    client = Client()
    client.force_login(user)
    return client


def page_socket(url: str, site, client: Client):
    cookie = f"{settings.SESSION_COOKIE_NAME}={client.cookies['sessionid'].value}"
    return connect(
        f"{url}/ws/sites/{site.code}", origin=ORIGIN, additional_headers={"Cookie": cookie}
    )


def close_code(socket) -> int:
    try:
        while True:
            socket.recv(timeout=10)
    except ConnectionClosed as closed:
        return closed.rcvd.code
    except TimeoutError:
        return 0  # still open


def withdraw_deactivated(user, site):
    user.is_active = False
    user.save()


def withdraw_off_the_site(user, site):
    SiteMembership.objects.filter(user=user, site=site).delete()


def withdraw_out_of_the_group(user, site):
    user.groups.remove(Group.objects.get(name="nurse"))


def withdraw_group_emptied(user, site):
    Group.objects.get(name="nurse").user_set.clear()  # the operator is in another group


@pytest.mark.parametrize(
    ("withdraw", "code"),
    [
        (withdraw_deactivated, 4401),
        (withdraw_off_the_site, 4403),
        (withdraw_out_of_the_group, 4403),
        (withdraw_group_emptied, 4403),
    ],
)
def test_the_socket_closes_when_access_is_withdrawn(daphne_url, site, withdraw, code):
    nurse = factories.user_create("kim", "nurse")
    operator = factories.user_create("lee", "operator")
    with (
        page_socket(daphne_url, site, signed_in(nurse)) as mine,
        page_socket(daphne_url, site, signed_in(operator)) as theirs,
    ):
        withdraw(nurse, site)

        assert close_code(mine) == code
        assert still_open(theirs)  # another user's page stays


def still_open(socket) -> bool:
    try:
        socket.recv(timeout=1)
    except TimeoutError:
        return True
    except ConnectionClosed:
        return False
    return True


def test_the_socket_closes_when_its_session_signs_out(daphne_url, site):
    client = signed_in(factories.user_create("kim", "nurse"))
    with page_socket(daphne_url, site, client) as socket:
        client.post("/accounts/logout/")
        assert close_code(socket) == 4401


def test_an_open_socket_checks_again_and_finds_its_session_expired(site, settings):
    settings.LIVE_ACCESS_RECHECK_SECONDS = 1
    client = signed_in(factories.user_create("kim", "nurse"))
    key = client.cookies["sessionid"].value
    cookie = (b"cookie", f"{settings.SESSION_COOKIE_NAME}={key}".encode())

    async def scenario():
        socket = WebsocketCommunicator(
            application, f"/ws/sites/{site.code}", headers=[(b"origin", ORIGIN.encode()), cookie]
        )
        connected, _ = await socket.connect(timeout=5)
        assert connected
        assert await socket.receive_nothing(timeout=1.5)  # checked once: still valid
        await expire(key)
        return await socket.receive_output(timeout=5)

    assert async_to_sync(scenario)() == {"type": "websocket.close", "code": 4401}


async def expire(key: str) -> None:
    await database_sync_to_async(
        lambda: Session.objects.filter(session_key=key).update(expire_date=timezone.now())
    )()
