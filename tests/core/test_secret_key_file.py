"""manage.py finds the secret key run.sh generated (var/secret_key, or SECRET_KEY_FILE) when
SECRET_KEY is not exported, so the README's commands work as written."""

import os
import subprocess
import sys

from django.conf import settings

PRINT_KEY = "from django.conf import settings; print(settings.SECRET_KEY)"


def run_django(env_changes: dict) -> subprocess.CompletedProcess:
    env = {key: value for key, value in os.environ.items() if key != "SECRET_KEY"}
    env.update(env_changes, DJANGO_SETTINGS_MODULE="hospital_delivery.settings", DEBUG="false")
    code = f"import django; django.setup(); {PRINT_KEY}"
    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=settings.BASE_DIR,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_it_reads_the_key_from_the_file_when_none_is_exported(tmp_path):
    key_file = tmp_path / "secret_key"
    key_file.write_text("a-key-run-sh-made\n")

    done = run_django({"SECRET_KEY_FILE": str(key_file)})

    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "a-key-run-sh-made"


def test_it_still_refuses_to_start_without_any_key(tmp_path):
    done = run_django({"SECRET_KEY_FILE": str(tmp_path / "missing")})

    assert done.returncode != 0
    assert "SECRET_KEY must be set" in done.stderr
