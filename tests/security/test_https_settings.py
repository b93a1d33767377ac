"""Deployment over HTTPS, switched on from the environment (docs/deployment/production.md)."""

import os
import subprocess
import sys

import pytest
import requests

from tests import servers

HTTPS_ENV = {
    "HTTPS": "true",
    "SECURE_PROXY_SSL_HEADER": "X-Forwarded-Proto=https",
    "DEBUG": "false",
    # check --deploy wants a long, random key (the tests' own is short).
    "SECRET_KEY": "k9#Qz2!vR8@pL5$wN1^xT7&mB4*cY6(hJ0)dF3-gS=aU+eW_iO~",
}


def manage(*args: str, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "manage.py", *args],
        cwd=servers.REPO,
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_check_deploy_is_clean_with_the_https_settings():
    result = manage("check", "--deploy", "--fail-level", "WARNING", env=HTTPS_ENV)

    assert result.returncode == 0, result.stdout + result.stderr
    assert "no issues" in result.stdout


def test_check_deploy_warns_without_them():
    env = {key: value for key, value in HTTPS_ENV.items() if key != "HTTPS"}

    result = manage("check", "--deploy", env={**env, "HTTPS": "false"})

    for warning in ("W004", "W008", "W012", "W016"):
        assert f"security.{warning}" in result.stdout + result.stderr


@pytest.fixture(scope="module")
def https_server(django_db_setup, django_db_blocker):
    with servers.gunicorn(workers=1, env=HTTPS_ENV) as url:
        yield url


def test_plain_http_is_redirected_to_https(https_server):
    response = requests.get(f"{https_server}/accounts/login/", allow_redirects=False, timeout=30)

    assert response.status_code == 301
    assert response.headers["Location"].startswith("https://")


def test_behind_the_tls_proxy_cookies_are_secure_and_hsts_is_sent(https_server):
    response = requests.get(
        f"{https_server}/accounts/login/",
        headers={"X-Forwarded-Proto": "https"},
        allow_redirects=False,
        timeout=30,
    )

    assert response.status_code == 200
    assert "max-age=31536000" in response.headers["Strict-Transport-Security"]
    assert "includeSubDomains" in response.headers["Strict-Transport-Security"]
    csrf = next(cookie for cookie in response.cookies if cookie.name == "csrftoken")
    assert csrf.secure
    assert "script-src 'self'" in response.headers["Content-Security-Policy"]
    assert response.headers["X-Frame-Options"] == "DENY"


def test_healthz_answers_plain_http_for_load_balancers(https_server):
    response = requests.get(f"{https_server}/healthz", allow_redirects=False, timeout=30)

    assert response.status_code in (200, 503)  # not redirected; no sweeps run here
    assert response.json()["database"] == "ok"
