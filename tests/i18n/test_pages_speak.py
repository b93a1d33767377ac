"""Every page, rendered in Korean and in Italian, keeps no phrase of the English catalog: what
a person reads went through translation (a missed word in a view or a template shows here)."""

import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from babel.messages.pofile import read_po
from django.conf import settings

from tests import factories
from tests.scheduling.conftest import request as order_task
from tests.ui.conftest import logged_in

LOCALE = Path(settings.BASE_DIR) / "locale"
READ_ATTRIBUTES = {"title", "placeholder", "aria-label", "alt", "data-confirm"}
PLACEHOLDER = re.compile(r"%\(\w+\)[sdr]|<[^>]+>")


class ReadText(HTMLParser):
    """The text a person reads on a page: text nodes outside scripts and styles, and the
    attributes read aloud or shown on hover."""

    def __init__(self):
        super().__init__()
        self.parts: list[str] = []
        self.skipping = 0

    def handle_starttag(self, tag, attrs):
        self.skipping += tag in ("script", "style")
        self.parts += [value for name, value in attrs if name in READ_ATTRIBUTES and value]

    def handle_endtag(self, tag):
        self.skipping -= tag in ("script", "style")

    def handle_data(self, data):
        if not self.skipping:
            self.parts.append(data)


def read_text(html: str) -> str:
    parser = ReadText()
    parser.feed(html)
    return " ".join(" ".join(parser.parts).split())


def english_phrases(language: str) -> set[str]:
    """The catalog's English pieces of two words or more that the language says otherwise."""
    with open(LOCALE / language / "LC_MESSAGES" / "django.po", "rb") as po:
        catalog = read_po(po)
    phrases = set()
    for message in catalog:
        english = message.id if isinstance(message.id, str) else message.id[-1]
        said = message.string if isinstance(message.string, str) else message.string[-1]
        if not english or english == said:
            continue
        for piece in PLACEHOLDER.split(english):
            piece = " ".join(piece.split()).strip(" .,:;()")
            if len(piece.split()) >= 2 and piece not in said:
                phrases.add(piece)
    return phrases


@pytest.fixture
def pages(site, db):
    admin = factories.staff_create("admin")
    factories.robot_create(site, "R1")
    task = order_task(site)
    station = "2F-LAB"
    urls = [
        "/",
        f"/deliveries/{task.code}/",
        "/stations/",
        f"/stations/{station}/",
        "/recurring/",
        "/fleet/",
        "/robots/R1/",
        "/reports/",
        "/webhooks/",
        "/audit/",
        f"/maps/{site.code}/edit",
        f"/maps/{site.code}/history",
        "/account/pin/",
    ]
    return logged_in(admin), urls


@pytest.mark.parametrize("language", ["ko", "it"])
def test_no_english_phrase_is_left_on_any_page(pages, language):
    client, urls = pages
    phrases = english_phrases(language)
    left = {}
    for url in urls:
        response = client.get(url, HTTP_ACCEPT_LANGUAGE=language)
        assert response.status_code == 200, url
        text = read_text(response.content.decode())
        found = sorted(phrase for phrase in phrases if phrase in text)
        if found:
            left[url] = found

    assert left == {}


def test_the_check_sees_a_phrase_left_in_english():
    html = '<p title="Floor map">Pianta <script>"Request delivery"</script> Request delivery</p>'

    assert read_text(html) == "Floor map Pianta Request delivery"
    assert {"Request delivery", "Floor map"} <= english_phrases("it") | {"Floor map"}
