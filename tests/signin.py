"""The test hospital's identities for the sign-in tests: who is in its LDAP directory
(tests/directory.py) and at its single sign-on provider (tests/oidc_provider.py), their groups,
and the ROLE_GROUPS and SITE_GROUPS that map those groups to roles and to the two test sites:
"tiny" (tests/factories.py) with its unit "Ward 3" (station 3F-WARD), and "other"."""

import re
from urllib.parse import urljoin, urlsplit

import requests

from accounts.groups import parse_role_groups, parse_site_groups
from tests.directory import GROUPS, Person
from tests.oidc_provider import Account

DN = f",{GROUPS}"

# LDAP groups by DN, the provider's groups by name: one mapping serves both.
ROLE_GROUPS = (
    f"nurse=cn=ward-nurses{DN}; operator=cn=fleet-operators{DN}; admin=cn=robot-admins{DN}; "
    "nurse=ward-nurses; operator=fleet-operators"
)
SITE_GROUPS = (
    f"tiny=cn=staff-tiny{DN}; tiny/3F-WARD=cn=ward-3{DN}; other=cn=staff-other{DN}; "
    "tiny=staff-tiny; other=staff-other"
)

DIRECTORY_PEOPLE = [
    Person("yoon", "Yoon", "Seo", ["ward-nurses", "ward-3"]),
    Person("han", "Han", "Bora", ["ward-nurses", "staff-tiny"]),
    Person("baek", "Baek", "Jiho", ["ward-nurses", "staff-tiny"]),
    Person("jang", "Jang", "Mina", ["ward-nurses", "staff-tiny"]),
    Person("lim", "Lim", "Taeho", ["robot-admins"]),
    Person("kwon", "Kwon", "Eun", ["robot-admins"]),
    Person("choi", "Choi", "Dana", ["fleet-operators", "staff-other"]),
]

PROVIDER_ACCOUNTS = [
    Account("a1f3-operator-song", "song", "Song", "Hyejin", ["fleet-operators", "staff-other"]),
    Account("b2e4-nurse-moon", "moon", "Moon", "Ara", ["ward-nurses", "staff-tiny"]),
]


def group_settings() -> dict:
    return {
        "ROLE_GROUPS": parse_role_groups(ROLE_GROUPS),
        "SITE_GROUPS": parse_site_groups(SITE_GROUPS),
    }


def provider_sign_in(authorization_url: str, username: str, password: str) -> str:
    """Sign in at the provider as a browser would (its login form), from the authorization
    request our server redirected to; returns where the provider sends the browser back."""
    browser = requests.Session()
    response = browser.get(authorization_url, timeout=30)
    action = re.search(r'<form method="post" action="([^"]+)"', response.text).group(1)
    response = browser.post(
        urljoin(response.url, action),
        data={"login": username, "password": password},
        allow_redirects=False,
        timeout=30,
    )
    provider = urlsplit(authorization_url).netloc
    while response.is_redirect:
        location = urljoin(response.url, response.headers["Location"])
        if urlsplit(location).netloc != provider:
            return location
        response = browser.get(location, allow_redirects=False, timeout=30)
    raise AssertionError(f"the provider did not send the browser back: {response.text[:500]}")
