"""The SQLite database (session keys, token hashes) and var/ secrets: owner-only."""

import os
import stat
import subprocess
import sys

from tests import servers


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_the_sqlite_database_is_created_readable_by_its_owner_only(tmp_path):
    database = tmp_path / "db.sqlite3"
    env = {**os.environ, "DATABASE_URL": f"sqlite:///{database}"}

    subprocess.run(
        [sys.executable, "manage.py", "migrate", "--noinput", "-v", "0"],
        cwd=servers.REPO,
        env=env,
        check=True,
        timeout=300,
        preexec_fn=lambda: os.umask(0o022),  # as a shell usually has it
    )

    assert mode(database) == 0o600
    for extra in tmp_path.glob("db.sqlite3-*"):
        assert mode(extra) == 0o600, extra


def test_run_sh_creates_its_files_owner_only():
    script = (servers.REPO / "scripts" / "run.sh").read_text()

    assert "umask 077" in script
    assert "chmod 700 var" in script
    assert 'chmod 600 "${file}"' in script  # var/secret_key
