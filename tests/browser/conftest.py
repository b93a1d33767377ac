"""Browser tests: Debian's Chromium, driven by Playwright, against the serving split of
docs/architecture/decisions/serving.md: gunicorn (pages, API, heartbeats) and daphne
(websockets) as subprocesses on the test database. Never `playwright install`: CHROMIUM_PATH
(default /usr/bin/chromium; ./scripts/test.sh installs Debian's package when missing)."""

from dataclasses import dataclass

import pytest
from django.conf import settings
from django.db import connections
from django.test import Client
from playwright.sync_api import expect, sync_playwright

from tests import servers

DESKTOP = {"width": 1280, "height": 900}
TABLET = {"width": 768, "height": 1024}


@dataclass
class Servers:
    http: str
    ws: servers.Daphne


@pytest.fixture(scope="session")
def page_servers(django_db_setup, django_db_blocker):
    with servers.celery_sink("browser") as queue, servers.daphne(env={"CELERY_QUEUE": queue}) as ws:
        env = {"CELERY_QUEUE": queue, "WEBSOCKET_URL": ws.url}
        with servers.gunicorn(workers=2, env=env) as http:
            yield Servers(http=http, ws=ws)


@pytest.fixture(scope="module", autouse=True)
def orm_beside_playwright():
    """Playwright's sync API keeps an asyncio loop in this thread; Django then refuses ORM calls
    as if they came from async code. They are plain blocking calls made while that loop waits
    (as Playwright's documentation for Django tests advises). For the whole module, as long as
    its Chromium (chromium_of_module) runs."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("DJANGO_ALLOW_ASYNC_UNSAFE", "true")
        yield


@pytest.fixture(scope="module")
def chromium_of_module(orm_beside_playwright):
    """One Chromium for a module's tests, as Playwright's own pytest plugin shares one browser:
    each test opens its own contexts (their cookies and storage apart) and a launch costs about a
    second. Not for the whole session: while Playwright runs, this thread has an asyncio loop,
    which the ORM calls of the other tests must not meet."""
    with sync_playwright() as playwright:
        browser = servers.chromium_launch(playwright)
        yield browser
        browser.close()
        connections.close_all()  # those the last test's flush opened, as below


@pytest.fixture
def chromium(transactional_db, chromium_of_module):
    """The module's Chromium, with no context of an earlier test left open."""
    yield chromium_of_module
    for context in chromium_of_module.contexts:
        context.close()
    # Connections the test opened while Playwright ran belong to that async context; close
    # them in it, or they outlive the test database.
    connections.close_all()


@pytest.fixture
def open_page(chromium, page_servers, site):
    """open_page(user, path, viewport=DESKTOP): a new browser context logged in as `user`
    (None: logged out) showing `path` of the test site, once its live connection is up."""

    def open_(user, path: str, *, viewport=DESKTOP, live=True):
        context = chromium.new_context(viewport=viewport, base_url=page_servers.http)
        if user is not None:
            client = Client()
            client.force_login(user)
            session = client.cookies[settings.SESSION_COOKIE_NAME].value
            cookie = {"name": settings.SESSION_COOKIE_NAME, "value": session}
            context.add_cookies([{**cookie, "url": page_servers.http}])
        page = context.new_page()
        page.goto(path)
        if live:
            expect(page.locator("#live-status")).to_have_text("Live")
        return page

    return open_
