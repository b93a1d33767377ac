"""A real directory and a real single sign-on provider for the sign-in tests of this package,
one of each per module; the settings that point this process at them, per test."""

import pytest

from tests import factories, signin
from tests.directory import Directory
from tests.oidc_provider import Provider

AXES = "axes.backends.AxesStandaloneBackend"
LOCAL = "django.contrib.auth.backends.ModelBackend"


@pytest.fixture(scope="module")
def directory():
    with Directory(signin.DIRECTORY_PEOPLE) as running:
        yield running


@pytest.fixture(scope="module")
def provider():
    with Provider(signin.PROVIDER_ACCOUNTS, server_urls=["http://testserver"]) as running:
        yield running


@pytest.fixture
def sites(db):
    """The two sites the groups name: tiny (with Ward 3) and other."""
    return factories.site_create(members=[]), factories.site_create(
        members=[], site="other", name="Other hospital"
    )


@pytest.fixture
def ldap_settings(settings, directory, sites):
    for name, value in {**directory.settings(), **signin.group_settings()}.items():
        setattr(settings, name, value)
    settings.AUTHENTICATION_BACKENDS = [
        AXES,
        "accounts.backends.DirectoryBackend",
        LOCAL,
        "accounts.backends.BadgePinBackend",
    ]
    return settings


@pytest.fixture
def sso_settings(settings, provider, sites):
    for name, value in {**provider.settings(), **signin.group_settings()}.items():
        setattr(settings, name, value)
    settings.AUTHENTICATION_BACKENDS = [
        AXES,
        "accounts.backends.SingleSignOnBackend",
        LOCAL,
        "accounts.backends.BadgePinBackend",
    ]
    return settings
