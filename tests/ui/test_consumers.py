"""The pages' websocket (/ws/sites/<site>): who may open it, and what it forwards."""

import pytest
from asgiref.sync import async_to_sync
from channels.db import database_sync_to_async
from channels.testing import WebsocketCommunicator
from django.conf import settings
from django.test import Client

from hospital_delivery.asgi import application
from tests import factories
from tests.scheduling.conftest import Beater, request

pytestmark = pytest.mark.django_db(transaction=True)

ORIGIN = (b"origin", b"http://127.0.0.1:8000")  # a page served by gunicorn, another port


def session_cookie(user) -> tuple[bytes, bytes]:
    client = Client()
    client.force_login(user)
    return (
        b"cookie",
        f"{settings.SESSION_COOKIE_NAME}={client.cookies['sessionid'].value}".encode(),
    )


def socket(site_code: str, *headers):
    return WebsocketCommunicator(application, f"/ws/sites/{site_code}", headers=list(headers))


def run(scenario):
    return async_to_sync(scenario)()


def closed_with(site_code: str, *headers):
    async def scenario():
        communicator = socket(site_code, *headers)
        connected, _ = await communicator.connect(timeout=5)
        closed = await communicator.receive_output(timeout=5)
        return connected, closed

    return run(scenario)


def test_it_closes_with_4401_for_anonymous_users(site):
    assert closed_with(site.code, ORIGIN) == (True, {"type": "websocket.close", "code": 4401})


def test_it_closes_with_4403_for_users_in_neither_group(site):
    outsider = factories.user_create("visitor")

    closed = closed_with(site.code, ORIGIN, session_cookie(outsider))

    assert closed == (True, {"type": "websocket.close", "code": 4403})


def test_it_closes_with_4404_for_an_unknown_site(site):
    nurse = factories.user_create("kim", "nurse")

    closed = closed_with("nowhere", ORIGIN, session_cookie(nurse))

    assert closed == (True, {"type": "websocket.close", "code": 4404})


@pytest.mark.parametrize(
    "origin", [(b"origin", b"http://evil.example"), (b"origin", b"null"), None]
)
def test_it_refuses_pages_from_other_origins(site, origin):
    nurse = factories.user_create("kim", "nurse")
    headers = [session_cookie(nurse), *([origin] if origin else [])]

    async def scenario():
        communicator = socket(site.code, *headers)
        connected, _ = await communicator.connect(timeout=5)
        return connected

    assert run(scenario) is False


def test_it_forwards_a_robots_new_state_to_an_operator(site, robot):
    cookie = session_cookie(factories.user_create("park", "operator"))

    async def scenario():
        communicator = socket(site.code, ORIGIN, cookie)
        connected, _ = await communicator.connect(timeout=5)
        assert connected
        await database_sync_to_async(Beater(robot).beat)(status="moving", battery=0.5)
        event = await communicator.receive_json_from(timeout=5)
        await communicator.disconnect()
        return event

    event = run(scenario)

    assert event["kind"] == "robot"
    assert set(event) == {"kind", "data"}
    assert {key: event["data"][key] for key in ("code", "presence", "status", "battery")} == {
        "code": "R1",
        "presence": "online",
        "status": "moving",
        "battery": 50,
    }


def test_it_forwards_a_new_task_to_a_nurse(site):
    nurse = factories.user_create("kim", "nurse")
    cookie = session_cookie(nurse)

    async def scenario():
        communicator = socket(site.code, ORIGIN, cookie)
        assert (await communicator.connect(timeout=5))[0]
        task = await database_sync_to_async(request)(site, user=nurse)
        event = await communicator.receive_json_from(timeout=5)
        await communicator.disconnect()
        return task, event

    task, event = run(scenario)

    assert event["kind"] == "task"
    assert event["data"]["code"] == task.code
    assert event["data"]["status"] == "due"


def test_it_forwards_only_its_own_sites_events(site, robot):
    cookie = session_cookie(factories.user_create("kim", "nurse"))
    other = factories.robot_create(factories.site_create(site="annex"), "A1")

    async def scenario():
        communicator = socket(site.code, ORIGIN, cookie)
        assert (await communicator.connect(timeout=5))[0]
        await database_sync_to_async(Beater(other).beat)()
        nothing = await communicator.receive_nothing(timeout=0.5)
        await communicator.disconnect()
        return nothing

    assert run(scenario)


def test_it_closes_a_sessions_sockets_when_that_session_logs_out(site, nurse):
    leaving, staying = Client(), Client()
    leaving.force_login(nurse)
    staying.force_login(nurse)

    def cookie(client):
        return (
            b"cookie",
            f"{settings.SESSION_COOKIE_NAME}={client.cookies['sessionid'].value}".encode(),
        )

    async def scenario():
        mine = socket(site.code, ORIGIN, cookie(leaving))
        other = socket(site.code, ORIGIN, cookie(staying))
        assert (await mine.connect(timeout=5))[0]
        assert (await other.connect(timeout=5))[0]
        await database_sync_to_async(leaving.post)("/accounts/logout/")
        closed = await mine.receive_output(timeout=5)
        await database_sync_to_async(request)(site, user=nurse)  # the other socket still hears
        event = await other.receive_json_from(timeout=5)
        await other.disconnect()
        return closed, event

    closed, event = run(scenario)

    assert closed == {"type": "websocket.close", "code": 4401}
    assert event["kind"] == "task"


def test_each_page_hears_an_event_in_its_own_language(site, robot):
    korean, english = (
        factories.user_create("kim", "nurse"),
        factories.user_create("park", "operator"),
    )
    accept_korean = (b"accept-language", b"ko-KR,ko;q=0.9")
    korean_cookie, english_cookie = session_cookie(korean), session_cookie(english)

    async def scenario():
        nurse = socket(site.code, ORIGIN, korean_cookie, accept_korean)
        operator = socket(site.code, ORIGIN, english_cookie)
        assert (await nurse.connect(timeout=5))[0]
        assert (await operator.connect(timeout=5))[0]
        await database_sync_to_async(Beater(robot).beat)(status="charging")
        heard = [await each.receive_json_from(timeout=5) for each in (nurse, operator)]
        for each in (nurse, operator):
            await each.disconnect()
        return heard

    in_korean, in_english = run(scenario)

    assert (in_korean["data"]["status_label"], in_english["data"]["status_label"]) == (
        "충전 중",
        "Charging",
    )
    assert in_korean["data"]["presence_label"] == "연결됨"
    assert set(in_korean) == {"kind", "data"}
    assert {key: value for key, value in in_korean["data"].items() if "label" not in key} == {
        key: value for key, value in in_english["data"].items() if "label" not in key
    }


def test_a_persons_chosen_language_beats_their_browsers_on_the_live_socket(site, robot):
    nurse = factories.user_create("kim", "nurse")
    client = Client()
    client.force_login(nurse)
    client.post("/language/", {"language": "it", "next": "/"})
    cookie = (
        b"cookie",
        f"{settings.SESSION_COOKIE_NAME}={client.cookies['sessionid'].value}".encode(),
    )

    async def scenario():
        page = socket(site.code, ORIGIN, cookie, (b"accept-language", b"ko-KR,ko"))
        assert (await page.connect(timeout=5))[0]
        await database_sync_to_async(Beater(robot).beat)(status="charging")
        event = await page.receive_json_from(timeout=5)
        await page.disconnect()
        return event

    assert run(scenario)["data"]["status_label"] == "In carica"
