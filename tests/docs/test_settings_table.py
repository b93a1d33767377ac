"""docs/administrators/settings.md has ONE table of every environment variable, and it is the
truth both ways: each variable the server's code reads (the env_* helpers of
hospital_delivery/env.py, os.environ, os.getenv) or the run command reads (`${NAME:-default}` in
scripts/run.sh and the Procfile) has a row, each row names a variable one of them reads, its
*read by* column says which, and a plain default in the code is the one documented.
"""

import ast
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TABLE = ROOT / "docs" / "administrators" / "settings.md"
HELPERS = {"env_str", "env_int", "env_bool", "env_list"}
RUN_COMMAND = [ROOT / "scripts" / "run.sh", ROOT / "Procfile"]


def _server_packages() -> list[Path]:
    """The server's components, as the import-linter contracts list them (robotsim, the robots'
    side, reads no setting of the server's)."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    names = config["tool"]["importlinter"]["root_packages"]
    return [ROOT / name for name in names if name != "robotsim"]


def _python_files():
    for package in _server_packages():
        for path in sorted(package.rglob("*.py")):
            if "migrations" not in path.parts:
                yield path


def _reads(tree: ast.AST):
    """(name, default node or None, line) of each environment read with a constant name; a read
    whose name is not a constant is yielded with the name None."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            func = node.func
            called = func.id if isinstance(func, ast.Name) else getattr(func, "attr", None)
            target = ast.unparse(func)
            if called in HELPERS or target in ("os.environ.get", "os.getenv"):
                first = node.args[0] if node.args else None
                name = first.value if isinstance(first, ast.Constant) else None
                default = node.args[1] if len(node.args) > 1 else None
                yield name, default, node.lineno
        elif (
            isinstance(node, ast.Subscript)
            and isinstance(node.ctx, ast.Load)
            and ast.unparse(node.value) == "os.environ"
        ):
            key = node.slice
            yield (key.value if isinstance(key, ast.Constant) else None), None, node.lineno


def _server_variables() -> dict[str, ast.AST | None]:
    found, unreadable = {}, []
    for path in _python_files():
        for name, default, line in _reads(ast.parse(path.read_text(), str(path))):
            if name is None:
                if path != ROOT / "hospital_delivery" / "env.py":  # the helpers themselves
                    unreadable.append(f"{path.relative_to(ROOT)}:{line}")
                continue
            found.setdefault(name, default)
    assert unreadable == [], "environment reads whose variable cannot be told from the code"
    return found


def _run_command_variables() -> set[str]:
    pattern = re.compile(r"\$\{([A-Z][A-Z0-9_]*):-")
    return {name for path in RUN_COMMAND for name in pattern.findall(path.read_text())}


def _documented() -> dict[str, dict[str, str]]:
    """The settings table's rows by variable: {"default", "read by", "meaning"}."""
    lines = TABLE.read_text().splitlines()
    start = lines.index("| variable | default | read by | meaning |")
    rows = {}
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [cell.strip() for cell in line.strip("|").split(" | ")]
        assert len(cells) == 4, line
        name = re.fullmatch(r"`([A-Z][A-Z0-9_]*)`", cells[0])
        assert name, f"one variable per row, in backticks: {line}"
        assert name.group(1) not in rows, f"{name.group(1)} has two rows"
        rows[name.group(1)] = {"default": cells[1], "read by": cells[2], "meaning": cells[3]}
    tables = sum(1 for line in lines if re.match(r"\|\s*-+\s*\|", line))
    assert tables == 1, "the settings page has one table"
    return rows


def test_it_documents_every_variable_the_code_reads_and_no_other():
    server, run = set(_server_variables()), _run_command_variables()
    documented = set(_documented())
    assert sorted(server - documented) == [], "read by the server, missing from the table"
    assert sorted(run - documented) == [], "read by the run command, missing from the table"
    assert sorted(documented - server - run) == [], "in the table, read by nothing"


def test_it_says_who_reads_each_variable():
    server, run = set(_server_variables()), _run_command_variables()
    for name, row in _documented().items():
        said = row["read by"]
        assert ("server" in said) == (name in server), name
        assert ("run.sh" in said) == (name in run), name
        assert row["meaning"], name


def test_its_defaults_are_the_codes_where_the_code_has_a_plain_one():
    checked = 0
    for name, default in _server_variables().items():
        if not isinstance(default, ast.Constant) or default.value in ("", 0, None):
            continue
        value = default.value
        shown = str(value).lower() if isinstance(value, bool) else str(value)
        cell = _documented()[name]["default"]
        if re.fullmatch(r"`[^`]*`", cell):
            assert cell == f"`{shown}`", name
            checked += 1
    assert checked >= 20
