"""The API schema and docs need a login, and the docs load nothing from outside the server."""

import re

import requests

from tests.security.conftest import logged_in_session


def test_the_schema_needs_a_login(live_server, site):
    response = requests.get(f"{live_server.url}/api/schema/?format=json", timeout=30)

    assert response.status_code == 401
    assert response.json()["error"] == "unauthorized"


def test_the_docs_page_sends_anonymous_users_to_the_login(live_server, site):
    response = requests.get(f"{live_server.url}/api/docs/", allow_redirects=False, timeout=30)

    assert response.status_code == 302
    assert response.headers["Location"].startswith("/accounts/login/")


def test_the_docs_load_every_file_from_this_server(live_server, nurse):
    session = logged_in_session(nurse)

    page = session.get(f"{live_server.url}/api/docs/", timeout=30)

    assert page.status_code == 200
    sources = re.findall(r'(?:src|href)="([^"]+)"', page.text)
    assert sources, page.text
    assert not [url for url in sources if "//" in url], sources  # all on this server
    for url in sources:
        loaded = session.get(f"{live_server.url}{url.replace('&amp;', '&')}", timeout=30)
        assert loaded.status_code == 200, url
    assert "<script>" not in page.text
    assert "<style>" not in page.text
    schema = session.get(f"{live_server.url}/api/schema/?format=json", timeout=30)
    assert schema.status_code == 200
    assert "/api/v1/tasks/" in schema.json()["paths"]
