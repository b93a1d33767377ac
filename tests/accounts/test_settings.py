"""The sign-in settings are read from the environment and stop the process on values that make
no sense; with none of them set, sign-in works as before (local accounts only)."""

import importlib.util

import pytest
from django.core.exceptions import ImproperlyConfigured

from hospital_delivery import settings as running

LDAP = {
    "AUTH_LDAP_SERVER_URI": "ldaps://dc1.hospital.org",
    "AUTH_LDAP_USER_SEARCH_BASE": "OU=Staff,DC=hospital,DC=org",
}
OIDC = {
    "OIDC_ISSUER": "https://login.hospital.org/realms/staff",
    "OIDC_CLIENT_ID": "hospital-delivery",
    "OIDC_CLIENT_SECRET": "s3cret",
}


def load(monkeypatch, **env):
    """hospital_delivery/settings.py executed afresh with `env` (a module of its own)."""
    for name, value in {"SECRET_KEY": "test", **env}.items():
        monkeypatch.setenv(name, value)
    spec = importlib.util.spec_from_file_location("settings_under_test", running.__file__)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_without_sign_in_settings_only_local_accounts_sign_in(monkeypatch):
    for name in [*LDAP, *OIDC, "ROLE_GROUPS", "SITE_GROUPS"]:
        monkeypatch.delenv(name, raising=False)

    loaded = load(monkeypatch)

    assert loaded.AUTHENTICATION_BACKENDS == [
        "axes.backends.AxesStandaloneBackend",
        "django.contrib.auth.backends.ModelBackend",
        "accounts.backends.BadgePinBackend",
    ]
    assert (loaded.ROLE_GROUPS, loaded.SITE_GROUPS) == ({}, {})


def test_a_directory_and_a_provider_add_their_backends(monkeypatch):
    loaded = load(monkeypatch, **LDAP, **OIDC, AUTH_LDAP_GROUP_SEARCH_BASE="OU=Groups,DC=x")

    assert loaded.AUTHENTICATION_BACKENDS[1:3] == [
        "accounts.backends.DirectoryBackend",
        "accounts.backends.SingleSignOnBackend",
    ]
    assert loaded.AUTH_LDAP_USER_SEARCH.filterstr == "(uid=%(user)s)"
    assert loaded.AUTH_LDAP_GROUP_SEARCH.base_dn == "OU=Groups,DC=x"
    assert (
        "https://login.hospital.org" in loaded.CONTENT_SECURITY_POLICY["DIRECTIVES"]["form-action"]
    )


@pytest.mark.parametrize(
    ("env", "error"),
    [
        ({**LDAP, "AUTH_LDAP_SERVER_URI": "dc1.hospital.org"}, "is not ldap:// or ldaps://"),
        ({**LDAP, "AUTH_LDAP_START_TLS": "true"}, "AUTH_LDAP_START_TLS is for ldap://"),
        ({**LDAP, "AUTH_LDAP_USER_SEARCH_BASE": ""}, "AUTH_LDAP_USER_SEARCH_BASE must be set"),
        ({**LDAP, "AUTH_LDAP_USER_SEARCH_FILTER": "(uid=x)"}, "must contain %\\(user\\)s"),
        ({**LDAP, "AUTH_LDAP_CA_FILE": "/nonexistent.pem"}, "is not a file"),
        ({"AUTH_LDAP_GROUP_TYPE": "ad"}, "use one of member, nested, posix"),
        ({"AUTH_LDAP_TIMEOUT": "0"}, "below its minimum 1"),
        ({**OIDC, "OIDC_ISSUER": "http://login.hospital.org"}, "must be an https:// URL"),
        ({**OIDC, "OIDC_CLIENT_SECRET": ""}, "OIDC_CLIENT_SECRET must be set"),
        ({**OIDC, "OIDC_SCOPES": "email profile"}, "must include openid"),
        ({"ROLE_GROUPS": "doctor=cn=doctors"}, "'doctor' is not a role"),
        ({"SITE_GROUPS": "tiny/=cn=x"}, "is not SITE or SITE/STATION"),
    ],
)
def test_values_that_make_no_sense_stop_the_process(monkeypatch, env, error):
    with pytest.raises(ImproperlyConfigured, match=error):
        load(monkeypatch, **env)
