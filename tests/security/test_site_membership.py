"""Users see and touch only the sites they belong to (staff users and superusers: every site).
A user of another site gets 404 (403 for a page about no site of theirs) and sees nothing."""

import pytest
from asgiref.sync import async_to_sync
from channels.testing import WebsocketCommunicator

from hospital_delivery.asgi import application
from robots.alerts import alert_raise
from robots.models import AlertKind
from scheduling.models import OperatorAction
from tests import factories
from tests.scheduling.conftest import request
from tests.security.conftest import ApiHttp, logged_in_session
from tests.ui.test_consumers import ORIGIN, session_cookie


@pytest.fixture
def other_site(site):
    return factories.site_create(site="other", name="Other hospital", members=[])


@pytest.fixture
def outsider(live_server, other_site):
    """An operator of the other site only."""
    user = factories.user_create("lee", "nurse", "operator", sites=[other_site])
    return ApiHttp(live_server.url, logged_in_session(user))


def post_form(http: ApiHttp, path: str, data: dict):
    """A page's form post: CSRF cookie from a page first, its token in the form."""
    http.get("/")
    token = http.session.cookies["csrftoken"]
    headers = {"Referer": http.base_url}
    return http.session.post(
        f"{http.base_url}{path}",
        data={**data, "csrfmiddlewaretoken": token},
        headers=headers,
        allow_redirects=False,
        timeout=30,
    )


def test_pages_of_another_site_answer_404(outsider, site, robot):
    task = request(site)

    assert outsider.get(f"/deliveries/{task.code}/").status_code == 404
    assert outsider.get("/robots/R1/").status_code == 404
    assert outsider.get(f"/live/{site.code}/state.json").status_code == 404
    assert outsider.get(f"/?site={site.code}").status_code == 404
    assert outsider.get(f"/fleet/?site={site.code}").status_code == 404


def test_a_user_sees_only_their_sites(outsider, site, other_site, robot):
    task = request(site)
    alert_raise(site_id=site.pk, kind=AlertKind.ROBOT_ERROR, key="k", message="Tiny on fire")

    page = outsider.get("/")

    assert page.status_code == 200
    assert "Other hospital" in page.text
    assert task.code not in page.text
    assert "Tiny on fire" not in page.text
    assert outsider.get(f"/live/{other_site.code}/state.json").status_code == 200


def test_actions_on_another_site_answer_404_and_change_nothing(outsider, site, robot):
    task = request(site)

    cancel = post_form(outsider, f"/deliveries/{task.code}/cancel", {})
    action = post_form(outsider, "/robots/R1/action", {"action": "pause"})

    assert cancel.status_code == 404
    assert action.status_code == 404
    task.refresh_from_db()
    assert task.status == "due"
    assert not OperatorAction.objects.exists()


def test_a_member_still_may(live_server, site, robot):
    member = ApiHttp(live_server.url, logged_in_session(factories.user_create("kim", "nurse")))
    task = request(site)

    assert member.get(f"/deliveries/{task.code}/").status_code == 200
    assert member.get("/robots/R1/").status_code == 200


def test_a_user_of_no_site_gets_403(live_server, site):
    user = factories.user_create("new", "nurse", sites=[])

    response = ApiHttp(live_server.url, logged_in_session(user)).get("/")

    assert response.status_code == 403
    assert "belongs to no site" in response.text


def test_staff_see_every_site(live_server, site, other_site, staff):
    admin = ApiHttp(live_server.url, logged_in_session(staff))

    assert admin.get(f"/?site={site.code}").status_code == 200
    assert admin.get(f"/?site={other_site.code}").status_code == 200


@pytest.mark.django_db(transaction=True)
def test_the_socket_of_another_site_closes_with_4403(site, other_site):
    user = factories.user_create("lee", "nurse", sites=[other_site])
    cookie = session_cookie(user)

    async def scenario():
        communicator = WebsocketCommunicator(
            application, f"/ws/sites/{site.code}", headers=[ORIGIN, cookie]
        )
        await communicator.connect(timeout=5)
        return await communicator.receive_output(timeout=5)

    assert async_to_sync(scenario)() == {"type": "websocket.close", "code": 4403}
