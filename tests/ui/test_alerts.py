"""Open alerts show on every page until an operator acknowledges them."""

import pytest

from robots.alerts import alert_raise
from robots.models import Alert, AlertKind
from tests import factories
from tests.scheduling.conftest import request


@pytest.fixture
def alert(site):
    robot = factories.robot_create(site, "R1")
    return alert_raise(
        site_id=site.pk,
        kind=AlertKind.OFFLINE_WITH_LOAD,
        key="offline-with-load:R1",
        message="R1 went offline carrying T-0042",
        robot=robot,
        task="T-0042",
    )


@pytest.mark.parametrize("url", ["/", "/fleet/", "/robots/R1/", "/deliveries/{task}/"])
def test_it_shows_open_alerts_on_every_page(nurse_client, site, alert, url):
    task = request(site)

    html = nurse_client.get(url.format(task=task.code)).content.decode()

    assert f'data-alert="{alert.pk}"' in html
    assert "R1 went offline carrying T-0042" in html
    assert "Robot offline with items on board" in html


def test_it_offers_acknowledge_to_operators_only(nurse_client, operator_client, alert):
    assert b">Acknowledge<" not in nurse_client.get("/").content
    assert b">Acknowledge<" in operator_client.get("/").content


def test_it_lets_an_operator_acknowledge_an_alert(operator_client, operator, alert):
    response = operator_client.post(f"/alerts/{alert.pk}/acknowledge", {"next": "/fleet/"})

    assert response["Location"] == "/fleet/"
    alert.refresh_from_db()
    assert alert.acknowledged_by == operator
    assert b"R1 went offline" not in operator_client.get("/fleet/").content


def test_it_forbids_nurses_to_acknowledge(nurse_client, alert):
    assert nurse_client.post(f"/alerts/{alert.pk}/acknowledge").status_code == 403
    assert Alert.objects.open().filter(pk=alert.pk).exists()


def test_it_goes_back_only_to_this_site(operator_client, alert):
    response = operator_client.post(
        f"/alerts/{alert.pk}/acknowledge", {"next": "https://evil.example/"}
    )

    assert response["Location"] == "/"
