"""Comments and docstrings say why the code is as it is, true for as long as the code is: no
dates, and none of a diary's words. History (what was measured when, what changed since) lives
in git and in bench/results/. Tests, migrations and the recorded benchmark runs may carry dates.
"""

import ast
import io
import re
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SKIPPED_DIRECTORIES = {".venv", "node_modules", "var", "tests", "migrations", ".git"}
DATE = re.compile(r"20[0-9]{2}-[0-9]{2}-[0-9]{2}")
# Phrases that only make sense on the day they were written.
DIARY = re.compile(
    r"\b(this|last|previous|next) session\b"
    r"|\bsession's (machine|code)\b"
    r"|\b(yesterday|this morning|this afternoon|last night|last week)\b"
    r"|\buntil (recently|now|this change)\b"
    r"|\bbefore this (change|work|round|issue)\b"
    r"|\bthe default then\b"
    r"|\bat the time of writing\b",
    re.IGNORECASE,
)


def _python_files():
    for path in sorted(ROOT.rglob("*.py")):
        relative = path.relative_to(ROOT)
        if SKIPPED_DIRECTORIES.isdisjoint(relative.parts) and relative.parts[:2] != (
            "bench",
            "results",
        ):
            yield path


def _comments_and_docstrings(source: str):
    """(line, text) of every comment and docstring."""
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            docstring = ast.get_docstring(node, clean=False)
            if docstring is not None:
                yield node.body[0].lineno, docstring


def test_it_finds_python_files_to_check():
    files = {str(path.relative_to(ROOT)) for path in _python_files()}
    assert "hospital_delivery/settings.py" in files
    assert "bench/heartbeat.py" in files
    assert not any(name.startswith("tests/") for name in files)


def test_no_python_file_outside_tests_and_migrations_has_a_date():
    dated = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in _python_files()
        for number, line in enumerate(path.read_text().splitlines(), start=1)
        if DATE.search(line)
    ]
    assert dated == []


def test_no_comment_or_docstring_reads_like_a_diary():
    diary = [
        f"{path.relative_to(ROOT)}:{line}: {DIARY.search(text).group(0)!r}"
        for path in _python_files()
        for line, text in _comments_and_docstrings(path.read_text())
        if DIARY.search(text)
    ]
    assert diary == []


def test_the_checks_catch_what_they_look_for():
    source = '"""Measured on 2026-11-27."""\n# faster than on the new session\'s machine\nx = 1\n'
    found = [text for _, text in _comments_and_docstrings(source)]
    assert any(DATE.search(text) for text in found)
    assert any(DIARY.search(text) for text in found)
    assert not DIARY.search("a session of the user; the session's cookie; sessions expire")
