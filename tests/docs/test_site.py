"""The documentation site as a reader gets it: built by MkDocs with --strict (as ./scripts/test.sh
does), served over HTTP from this machine and opened in Debian's Chromium with every request
recorded. Every page in its navigation opens, every page of docs/ is in that navigation, search
finds what a newcomer asks, and nothing outside the site is ever requested: hospital intranets
are often cut off from the internet, so the site may load no web font, CDN or external script.
"""

import functools
import http.server
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import urljoin

import pytest
from playwright.sync_api import expect, sync_playwright

from tests import servers

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    site = tmp_path_factory.mktemp("site")
    finished = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert finished.returncode == 0, finished.stdout + finished.stderr
    return site


@pytest.fixture(scope="module")
def served(built):
    handler = functools.partial(_QuietHandler, directory=str(built))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):
        pass


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as playwright:
        chromium = servers.chromium_launch(playwright)
        yield chromium
        chromium.close()


def _pages_of_docs() -> set[str]:
    """The HTML page each Markdown file of docs/ becomes (use_directory_urls: false)."""
    return {str(path.relative_to(DOCS).with_suffix(".html")) for path in DOCS.rglob("*.md")}


def test_it_opens_every_page_of_the_navigation_and_requests_nothing_outside_the_site(
    served, browser
):
    context = browser.new_context(base_url=served)
    requested = []
    context.on("request", lambda request: requested.append(request.url))
    page = context.new_page()
    page.goto("index.html")
    links = page.eval_on_selector_all(
        "nav.md-nav--primary a.md-nav__link[href]", "links => links.map(a => a.href)"
    )
    navigation = {urljoin(served, link).split("#")[0] for link in links}
    assert {link.removeprefix(served) for link in navigation} == _pages_of_docs()

    for url in sorted(navigation):
        response = page.goto(url)
        assert response is not None, url
        assert response.ok, url
        expect(page.locator("article h1").first).to_be_visible()

    outside = [url for url in requested if not url.startswith((served, "data:", "blob:"))]
    assert outside == []
    # The theme's own style sheet and scripts came from the site itself.
    assert any(url.endswith(".css") for url in requested)
    assert any(url.endswith(".js") for url in requested)
    context.close()


@pytest.mark.parametrize(
    ("question", "answer"),
    [
        ("unreachable", "nurses/statuses.html"),
        ("VDA 5050", "integrators/vda5050.html"),
        ("TLS", "deployment/production.html"),
    ],
)
def test_its_search_answers_a_newcomers_questions_without_the_internet(
    served, browser, question, answer
):
    context = browser.new_context(base_url=served)
    requested = []
    context.on("request", lambda request: requested.append(request.url))
    page = context.new_page()
    page.goto("index.html")
    _search(page, question)
    expect(page.locator(f".md-search-result__item a[href*='{answer}']").first).to_be_attached()
    assert [url for url in requested if not url.startswith((served, "data:", "blob:"))] == []
    context.close()


def test_it_reads_from_a_file_without_a_server(built, browser):
    context = browser.new_context()
    requested = []
    context.on("request", lambda request: requested.append(request.url))
    page = context.new_page()
    page.goto((built / "nurses" / "statuses.html").as_uri())
    expect(page.get_by_role("heading", name="Robots: online, unreachable, offline")).to_be_visible()
    production = "nav.md-nav--primary a.md-nav__link[href$='deployment/production.html']"
    page.locator(production).first.click()
    heading = page.get_by_role("heading", level=1, name="Production behind nginx with TLS")
    expect(heading).to_be_visible()
    # Search runs in a Web Worker, which file:// pages may not start: the site's own shim does.
    _search(page, "unreachable")
    expect(
        page.locator(".md-search-result__item a[href*='nurses/statuses.html']").first
    ).to_be_attached()
    assert [url for url in requested if not url.startswith(("file:", "data:", "blob:"))] == []
    context.close()


def _search(page, question: str, *, timeout: float = 60.0) -> None:
    """Type `question` into the search box, key by key as a reader does, until results show.

    Material for MkDocs reads the box on a key released, on focus and when its search index is
    ready, never on a value merely set (Playwright's `fill`), and it ignores a question equal to
    the last it read: each try clears the box and types the question again."""
    box = page.locator("input.md-search__input")
    results = page.locator(".md-search-result__item").first
    deadline = time.monotonic() + timeout
    while True:
        box.fill("")
        box.press_sequentially(question)
        try:
            expect(results).to_be_attached(timeout=3_000)
            return
        except AssertionError:
            if time.monotonic() > deadline:
                raise
