"""Every page needs a login; users in neither group get 403; the groups come from a migration."""

import importlib

import pytest
from django.apps import apps
from django.contrib.auth.models import Group

from tests import factories
from tests.scheduling.conftest import request as order_task
from tests.ui.conftest import logged_in

PAGES = [
    "/",
    "/fleet/",
    "/robots/R1/",
    "/deliveries/{task}/",
    "/live/tiny/state.json",
]
POSTS = [
    "/deliveries/{task}/cancel",
    "/robots/R1/action",
    "/alerts/1/acknowledge",
]


@pytest.fixture
def pages(site):
    """Formats the URLs above with a task that exists."""
    factories.robot_create(site, "R1")
    task = order_task(site)
    return lambda url: url.format(task=task.code)


@pytest.mark.parametrize("url", PAGES + POSTS)
def test_it_sends_anonymous_users_to_the_login_page(client, pages, url):
    response = client.post(pages(url)) if url in POSTS else client.get(pages(url))

    assert response.status_code == 302
    assert response["Location"].startswith("/accounts/login/?next=")


@pytest.mark.parametrize("url", PAGES + POSTS)
def test_it_refuses_users_in_neither_group(outsider, pages, url):
    client = logged_in(outsider)

    data = {"action": "pause"}
    response = client.post(pages(url), data) if url in POSTS else client.get(pages(url))

    assert response.status_code == 403


@pytest.mark.parametrize("who", ["nurse", "operator", "staff"])
@pytest.mark.parametrize("url", PAGES)
def test_it_lets_nurses_operators_and_staff_in(request, pages, who, url):
    user = request.getfixturevalue(who) if who != "staff" else factories.staff_create("admin")

    assert logged_in(user).get(pages(url)).status_code == 200


def test_it_shows_the_login_form_with_labelled_fields(client):
    response = client.get("/accounts/login/")

    assert response.status_code == 200
    assert b'<label for="id_username">Username' in response.content
    assert b'<label for="id_password">Password' in response.content


def test_it_creates_the_nurse_and_operator_groups_once(db):
    migration = importlib.import_module("hospital_delivery.migrations.0002_page_groups")
    Group.objects.all().delete()

    migration.groups_create(apps, None)
    migration.groups_create(apps, None)

    assert sorted(Group.objects.values_list("name", flat=True)) == ["nurse", "operator"]
