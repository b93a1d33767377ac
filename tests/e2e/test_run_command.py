"""THE run command, ./scripts/run.sh, as a person runs it: in a fresh copy of the repository (its
own SQLite database, var/ and secret key), then Ctrl-C.

After start the terminal shows the demo logins last and then only deliveries, alerts and errors,
every process's log times in one zone; Ctrl-C stops every process within honcho's grace period
(none SIGKILLed); `manage.py` then works as the docs show it, without exporting the key.
"""

import os
import re
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from tests import servers

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("nginx") is None, reason="./scripts/test.sh installs nginx"),
]

COPY_IGNORED = shutil.ignore_patterns(
    ".git", ".venv", "node_modules", "var", "db.sqlite3*", "staticfiles", "__pycache__", ".*cache"
)
# honcho's prefix: "11:26:53 ws.1       | the process's line"
PREFIXED = re.compile(r"^(\d\d):(\d\d):(\d\d) (\S+)\s+\| (.*)$")
# A time inside a process's own line: Python's logging, gunicorn's, nginx's, daphne's.
EMBEDDED_TIME = re.compile(r"\d{4}[-/]\d\d[-/]\d\d[ T](\d\d):(\d\d):(\d\d)")


class Terminal:
    """run.sh in its own session, its output (stdout and stderr, as a terminal shows both) read
    line by line in a thread."""

    def __init__(self, command, *, cwd: Path, env: dict):
        self.process = subprocess.Popen(
            command,
            cwd=cwd,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, pattern: str, *, after: int = 0, timeout: float) -> int:
        """The index of the first line from `after` on that matches."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for index in range(after, len(self.lines)):
                if re.search(pattern, self.lines[index]):
                    return index
            if self.process.poll() is not None and not self._reader.is_alive():
                break
            time.sleep(0.1)
        tail = "\n".join(self.lines[-40:])
        raise AssertionError(f"no line matching {pattern!r} within {timeout} s:\n{tail}")

    def interrupt(self) -> float:
        """Ctrl-C: SIGINT to the terminal's whole process group; seconds until run.sh exited."""
        started = time.monotonic()
        os.killpg(self.process.pid, signal.SIGINT)
        self.process.wait(timeout=30)
        self._reader.join(timeout=10)
        return time.monotonic() - started


@pytest.fixture
def checkout(tmp_path):
    """A fresh copy of the working tree, sharing the virtual environment."""
    copy = tmp_path / "hospital_delivery"
    shutil.copytree(servers.REPO, copy, ignore=COPY_IGNORED, symlinks=True)
    (copy / ".venv").symlink_to((servers.REPO / ".venv").resolve())
    return copy


@pytest.fixture
def run_env():
    env = {
        name: value
        for name, value in os.environ.items()
        # As a person starts it: the SQLite database of the checkout, the generated key.
        if name not in {"DATABASE_URL", "SECRET_KEY", "TZ", "LOG_LEVEL", "DATABASE_CONN_MAX_AGE"}
    }
    return {
        **env,
        "PORT_HTTP": str(servers.free_port()),
        "PORT_WS": str(servers.free_port()),
        "PORT_WEB": str(servers.free_port()),
        "PORT_WEB_WOKEN": str(servers.free_port()),
        # A Redis database and MQTT topics of its own: other tests' workers share the machine's.
        "REDIS_URL": "redis://127.0.0.1:6379/13",
        "VDA5050_INTERFACE": "runcommandtest",
        "FLEET_VDA5050": "0",
        # A random delivery every few seconds of real time, so one shows soon after start.
        "FLEET_TRAFFIC": "40",
    }


def seconds_of_day(hours: str, minutes: str, seconds: str) -> int:
    return int(hours) * 3600 + int(minutes) * 60 + int(seconds)


def test_it_shows_logins_then_deliveries_in_one_zone_and_stops_cleanly(checkout, run_env):
    terminal = Terminal(["./scripts/run.sh"], cwd=checkout, env=run_env)
    try:
        logins = terminal.wait_for(r"^  nurse\s", timeout=240)
        terminal.wait_for(r"activity: delivery T-\d+", after=logins, timeout=90)
    finally:
        stopped_in = terminal.interrupt()
    lines = terminal.lines
    sigint = next(i for i, line in enumerate(lines) if "SIGINT received" in line)
    started = {
        m[1]: int(m[2]) for m in map(re.compile(r"(\S+) started \(pid=(\d+)\)").search, lines) if m
    }
    stopped = {
        m[1]: m[2] for m in map(re.compile(r"(\S+) stopped \(rc=(-?\d+)\)").search, lines) if m
    }

    # After the logins, until Ctrl-C: deliveries and alerts, or what went wrong; nothing else.
    chatter = [
        line
        for line in lines[logins + 1 : sigint]
        if not re.search(r"INFO activity:|WARNING|ERROR|CRITICAL", line)
    ]
    assert chatter == []
    # Each process's own times are in the zone of honcho's prefix (the site's, said above).
    for line in lines:
        prefixed, embedded = PREFIXED.match(line), EMBEDDED_TIME.search(line)
        if prefixed and embedded:
            apart = seconds_of_day(*prefixed.groups()[:3]) - seconds_of_day(*embedded.groups())
            assert min(apart % 86400, -apart % 86400) <= 60, line
    assert "log times are in Asia/Seoul" in "\n".join(lines[:logins])
    # Ctrl-C: every process stopped by itself within honcho's grace period, none SIGKILLed.
    assert stopped_in < 5
    assert not any("SIGKILL" in line for line in lines)
    assert set(stopped) == set(started)
    assert "-9" not in stopped.values(), stopped
    for pid in started.values():
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
    assert not [cwd for cwd in Path("/proc").glob("[0-9]*/cwd") if _points_into(cwd, checkout)]

    # manage.py as the docs show it, without exporting the key run.sh generated.
    token = subprocess.run(
        [".venv/bin/python", "manage.py", "robot_token", "R3"],
        cwd=checkout,
        env=run_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert token.returncode == 0, token.stderr
    assert token.stdout.strip()


def _points_into(link: Path, directory: Path) -> bool:
    """Whether a process's working directory (a /proc/<pid>/cwd link) is in `directory`."""
    try:
        return Path(os.readlink(link)).is_relative_to(directory)
    except OSError:  # the process is gone, or not ours to look at
        return False
