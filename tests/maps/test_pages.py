"""The map pages: the editor and the history for administrators only, each version's export,
and rolling back from the history page."""

import copy

import pytest
from django.test import Client

from maps.documents import site_document
from maps.models import MapVersion
from maps.services import draft_open, draft_publish, draft_save
from robots.models import Site
from robots.sitefile import site_file_parse


@pytest.fixture
def admin_client(staff):
    client = Client()
    client.force_login(staff)
    return client


@pytest.mark.parametrize("path", ["/maps/tiny/edit", "/maps/tiny/history"])
def test_it_shows_the_map_pages_to_administrators_only(site, nurse, operator, admin_client, path):
    for user in (nurse, operator):
        client = Client()
        client.force_login(user)
        assert client.get(path).status_code == 403
    assert Client().get(path).status_code == 302  # to the login page
    assert admin_client.get(path).status_code == 200


def test_it_exports_a_version_as_a_site_file_download(site, admin_client):
    admin_client.get("/maps/tiny/history")  # records the loaded map as version 1

    response = admin_client.get("/maps/tiny/versions/1.yaml")

    assert response.status_code == 200
    assert response["Content-Disposition"] == 'attachment; filename="tiny-map-v1.yaml"'
    assert site_file_parse(response.content.decode(), name="v1.yaml") == site_document(site)
    assert admin_client.get("/maps/tiny/versions/7.yaml").status_code == 404


def test_it_rolls_back_from_the_history_page(site, staff, admin_client):
    draft = draft_open(site=site)
    document = copy.deepcopy(draft.document)
    document["name"] = "Renamed"
    draft = draft_save(site=site, document=document, revision=draft.revision, user=staff)
    draft_publish(site=site, revision=draft.revision, user=staff, note="new name")
    page = admin_client.get("/maps/tiny/history").content.decode()
    assert "new name" in page
    assert "Roll back to version 1" in page

    response = admin_client.post("/maps/tiny/versions/1/restore", follow=True)

    assert "Version 1 restored as version 3." in response.content.decode()
    assert Site.objects.get(pk=site.pk).name == "Tiny test hospital"
    assert MapVersion.objects.get(site=site, number=3).restored_from == 1
