"""The style sheets parse as CSS (tinycss2, a parser that follows CSS Syntax Level 3): a block
left open makes the browser drop every rule after it without a word, so it fails here."""

from pathlib import Path

import pytest
import tinycss2
from django.conf import settings

STYLE_SHEETS = sorted((Path(settings.BASE_DIR) / "static" / "css").glob("*.css"))
# Blocks whose contents are rules; any other at-rule holds declarations (@font-face, @page).
RULE_BLOCKS = {"media", "supports", "layer", "container"}


def problems(css: str) -> list[str]:
    """Where the sheet is not what a browser would apply as written: parse errors, and rules
    nested inside a style rule (this project writes no CSS nesting, so one is a block left
    open above it)."""
    found = []
    _check_rules(tinycss2.parse_stylesheet(css, skip_comments=True, skip_whitespace=True), found)
    return found


def _check_rules(rules, found: list[str]) -> None:
    for rule in rules:
        if rule.type == "error":
            found.append(f"line {rule.source_line}: {rule.message}")
        elif rule.type == "at-rule" and rule.lower_at_keyword in RULE_BLOCKS:
            _check_rules(_contents(rule), found)
        elif rule.type in ("qualified-rule", "at-rule"):
            _check_declarations(rule, found)


def _check_declarations(rule, found: list[str]) -> None:
    for item in _contents(rule):
        if item.type == "error":
            found.append(f"line {item.source_line}: {item.message}")
        elif item.type == "qualified-rule":
            selector = tinycss2.serialize(item.prelude).strip()
            found.append(
                f"line {item.source_line}: rule {selector!r} inside the block opened on "
                f"line {rule.source_line}: is that block closed?"
            )


def _contents(rule):
    if rule.content is None:
        return []
    return tinycss2.parse_blocks_contents(rule.content, skip_comments=True, skip_whitespace=True)


@pytest.mark.parametrize("path", STYLE_SHEETS, ids=lambda path: path.name)
def test_it_parses_every_style_sheet_without_a_problem(path):
    assert problems(path.read_text(encoding="utf-8")) == []


def test_it_finds_a_block_left_open():
    css = ".card textarea {\n  width: 100%;\n\n/* Out of service. */\n.resources tr.out td {\n"
    css += "  background: pink;\n}\n\n.status-bad {\n  color: red;\n}\n"
    assert problems(css) == [
        "line 5: rule '.resources tr.out td' inside the block opened on line 1: is that block "
        "closed?",
        "line 9: rule '.status-bad' inside the block opened on line 1: is that block closed?",
    ]


def test_it_finds_a_declaration_without_a_colon():
    assert problems("@media (max-width: 600px) {\n  .a {\n    color red;\n  }\n}\n") != []


def test_it_passes_the_project_s_kinds_of_rules():
    css = "@media (max-width: 600px) { .a { color: red; } }\n@font-face { font-family: x; }\n"
    css += ".b:hover { --level: 40%; }\n"
    assert problems(css) == []
