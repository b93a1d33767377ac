"""Every word a person reads on our pages goes through translation: a template's text between
tags, and the attributes people read (a title, a placeholder, an ARIA label, a confirmation),
are inside {% translate %} or {% blocktranslate %}. Variables, tags and codes are not words."""

import re
from pathlib import Path

import pytest
from django.conf import settings
from django.template.base import Lexer, TokenType
from django.template.loader import get_template

TEMPLATES = Path(settings.BASE_DIR) / "templates"
# Swagger UI's page is a third party's and speaks English only, like the API it documents.
NOT_OURS = {"api/swagger_ui.html"}
READ_ATTRIBUTES = ("title", "placeholder", "aria-label", "alt", "data-confirm", "label")
WORD = re.compile(r"[^\W\d_]{2,}")
TAG_NAME = re.compile(r"</?([a-zA-Z0-9]+)")
ENTITY = re.compile(r"&[a-z]+;|&#\d+;")
LITERAL_ATTRIBUTE = re.compile(r"\b(" + "|".join(READ_ATTRIBUTES) + r')="([^"{]*)"')


def words_outside_translation(source: str) -> list[str]:
    """The text a person would read that no translation tag covers."""
    found = []
    in_translation = in_tag = in_code = False
    for token in Lexer(source).tokenize():
        if token.token_type == TokenType.BLOCK:
            name = token.contents.split()[0]
            in_translation = name == "blocktranslate" or (
                in_translation and name != "endblocktranslate"
            )
            continue
        if token.token_type != TokenType.TEXT or in_translation:
            continue
        for is_tag, chunk in html_chunks(token.contents, in_tag):
            in_tag = is_tag and not chunk.endswith(">")
            if is_tag:
                tag = TAG_NAME.match(chunk)
                if tag:
                    in_code = tag.group(1).lower() in ("script", "style") and not tag.group(
                        0
                    ).startswith("</")
                found += [
                    value for _, value in LITERAL_ATTRIBUTE.findall(chunk) if WORD.search(value)
                ]
            elif not in_code and WORD.search(ENTITY.sub("", chunk)):
                found.append(chunk.strip())
    return found


def html_chunks(text: str, in_tag: bool):
    """(is_tag, chunk) pieces of a text token, carrying whether it began inside a tag."""
    chunk = ""
    for at, char in enumerate(text):
        following = text[at + 1 : at + 2]
        opens = following.isalpha() or following in ("/", "!")
        if not in_tag and char == "<" and opens:
            if chunk:
                yield False, chunk
            chunk, in_tag = char, True
        elif in_tag and char == ">":
            yield True, chunk + char
            chunk, in_tag = "", False
        else:
            chunk += char
    if chunk:
        yield in_tag, chunk


def our_templates():
    for path in sorted(TEMPLATES.rglob("*.html")):
        name = path.relative_to(TEMPLATES).as_posix()
        if name not in NOT_OURS:
            yield name


@pytest.mark.parametrize("name", list(our_templates()))
def test_every_word_of_the_template_is_translated(name):
    get_template(name)  # its translation tags load and parse

    assert words_outside_translation((TEMPLATES / name).read_text()) == []


def test_the_check_finds_a_word_left_out():
    source = '{% load i18n %}<p title="Hello there">{% translate "Fine" %} Left out</p>{{ code }}'

    assert words_outside_translation(source) == ["Hello there", "Left out"]
