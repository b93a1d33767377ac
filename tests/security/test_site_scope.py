"""Reports, their CSVs, webhooks and /metrics follow the pages' membership rules: an operator of
one site sees nothing of another (404 for a page about it), staff and the metrics token see
every site."""

import pytest
import requests
from django.test import override_settings
from django.utils import timezone

from reports.seed import history_seed
from tests import factories
from tests.scheduling.conftest import request as task_request
from tests.security.conftest import ApiHttp, logged_in_session
from webhooks.models import Subscription, WebhookDelivery

TOKEN = "scope-scrape-token"


@pytest.fixture
def other_site(site):
    return factories.site_create(site="other", name="Other hospital", members=[])


@pytest.fixture
def outsider(live_server, other_site):
    """An operator of the other site only."""
    user = factories.user_create("lee", "operator", sites=[other_site])
    return ApiHttp(live_server.url, logged_in_session(user))


@pytest.fixture
def busy_site(site):
    factories.robot_create(site, "R1")
    history_seed(site=site, deliveries=40, days=3, end=timezone.now(), seed=5)
    return site


def test_reports_of_another_site_answer_404(outsider, busy_site, other_site):
    for path in ("/reports/", "/reports/by_ward.csv", "/reports/by_priority.csv"):
        response = outsider.get(f"{path}?site={busy_site.code}")
        assert response.status_code == 404, path
        assert "Ward" not in response.text

    own = outsider.get("/reports/by_ward.csv")  # no site named: the user's own

    assert own.status_code == 200
    assert f"{other_site.code}-by_ward-" in own.headers["Content-Disposition"]
    assert len(own.text.strip().splitlines()) == 1  # the header only: no rows of site A
    assert busy_site.name not in outsider.get("/reports/").text


def test_a_member_and_staff_still_read_the_sites_reports(live_server, busy_site, staff):
    member = ApiHttp(live_server.url, logged_in_session(factories.user_create("op", "operator")))
    admin = ApiHttp(live_server.url, logged_in_session(staff))

    for http in (member, admin):
        csv = http.get(f"/reports/by_ward.csv?site={busy_site.code}")
        assert csv.status_code == 200
        assert len(csv.text.strip().splitlines()) > 1


def test_the_webhooks_page_shows_only_the_users_sites(outsider, site, other_site, settings):
    settings.WEBHOOK_ALLOWED_NETWORKS = ["127.0.0.0/8"]
    Subscription.objects.create(site=site, name="Lab of A", url="http://127.0.0.1:9/secret-a")
    Subscription.objects.create(site=other_site, name="Lab of B", url="http://127.0.0.1:9/b")
    task_request(site)
    assert WebhookDelivery.objects.filter(subscription__site=site).exists()

    page = outsider.get("/webhooks/").text

    assert "Lab of B" in page
    assert "Lab of A" not in page
    assert "secret-a" not in page
    assert "task-transition-" not in page  # no delivery of site A


@override_settings(METRICS_TOKEN=TOKEN)
def test_metrics_list_an_operators_own_sites_and_every_site_for_staff_and_the_token(
    live_server, outsider, site, other_site, staff
):
    factories.robot_create(site, "RA")
    factories.robot_create(other_site, "RB")
    admin = ApiHttp(live_server.url, logged_in_session(staff))
    scraper = ApiHttp(live_server.url, requests.Session())
    scraper.session.headers["Authorization"] = f"Bearer {TOKEN}"

    mine = outsider.get("/metrics").text
    every = [admin.get("/metrics").text, scraper.get("/metrics").text]

    assert f'site="{other_site.code}"' in mine
    assert f'site="{site.code}"' not in mine
    assert 'robot="RA"' not in mine
    for text in every:
        assert f'site="{site.code}"' in text
        assert f'site="{other_site.code}"' in text
