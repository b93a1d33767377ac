"""Signing in with the hospital's LDAP directory (django-auth-ldap), against a real slapd: the
account, its roles and sites from its groups at each sign-in, and what the directory refuses."""

from contextlib import contextmanager

from axes.models import AccessAttempt
from django.contrib.auth import get_user_model
from django.contrib.auth.signals import user_logged_in, user_login_failed
from django.test import Client

from accounts.choices import Source
from robots.models import SiteMembership
from tests import factories
from tests.directory import PASSWORD, Directory, Person, person_dn

User = get_user_model()


def sign_in(username: str, password: str = PASSWORD) -> tuple[Client, object]:
    client = Client()
    response = client.post("/accounts/login/", {"username": username, "password": password})
    return client, response


@contextmanager
def captured(signal):
    """The keyword arguments of each sending of `signal` while the block runs."""
    seen = []

    def receiver(**kwargs):
        seen.append(kwargs)

    signal.connect(receiver, weak=False)
    try:
        yield seen
    finally:
        signal.disconnect(receiver)


def signed_in(client: Client) -> bool:
    return "_auth_user_id" in client.session


def roles(username: str) -> set[str]:
    return set(User.objects.get(username=username).groups.values_list("name", flat=True))


def memberships(username: str) -> dict[str, str | None]:
    rows = SiteMembership.objects.filter(user__username=username).select_related("site", "unit")
    return {m.site.code: (m.unit.code if m.unit else None) for m in rows}


def test_it_signs_in_a_directory_nurse_with_her_role_and_unit(ldap_settings):
    with captured(user_logged_in) as seen:
        client, response = sign_in("yoon")

    assert response.status_code == 302
    assert signed_in(client)
    user = User.objects.get(username="yoon")
    assert (user.first_name, user.last_name, user.email) == ("Yoon", "Seo", "yoon@hospital.test")
    assert not user.has_usable_password()  # the directory checks it, never this server
    assert (user.account.source, user.account.subject) == (Source.LDAP, person_dn("yoon"))
    assert roles("yoon") == {"nurse"}
    assert memberships("yoon") == {"tiny": "3F-WARD"}
    assert [event["user"] for event in seen] == [user]
    assert client.get("/").status_code == 200  # the deliveries page, as a nurse


def test_a_user_removed_from_a_group_loses_what_it_gave_at_next_sign_in(ldap_settings, directory):
    sign_in("han")
    assert roles("han") == {"nurse"}
    assert memberships("han") == {"tiny": None}

    directory.group_remove("ward-nurses", "han")
    directory.group_remove("staff-tiny", "han")
    client, response = sign_in("han")

    assert signed_in(client)  # the directory still knows her
    assert roles("han") == set()
    assert memberships("han") == {}
    assert client.get("/").status_code == 403  # neither nurse nor operator any more


def test_a_disabled_directory_account_cannot_sign_in(ldap_settings, directory):
    assert signed_in(sign_in("baek")[0])
    directory.disable("baek")
    with captured(user_login_failed) as failed:
        client, response = sign_in("baek")

    assert response.status_code == 200
    assert "Please enter a correct username and password" in response.content.decode()
    assert not signed_in(client)
    assert failed[0]["credentials"]["username"] == "baek"
    assert failed[0]["credentials"]["password"] != PASSWORD  # Django masks it


def test_wrong_directory_passwords_are_throttled_like_local_ones(ldap_settings):
    for _ in range(ldap_settings.AXES_FAILURE_LIMIT):
        assert sign_in("jang", "wrong")[1].status_code in (200, 429)

    client, response = sign_in("jang")  # the right password, too late

    assert response.status_code == 429
    assert not signed_in(client)
    assert AccessAttempt.objects.get(username="jang").failures_since_start >= 5


def test_the_admins_group_makes_an_administrator(ldap_settings):
    client, _ = sign_in("lim")

    user = User.objects.get(username="lim")
    assert (user.is_staff, user.is_superuser) == (True, True)
    assert client.get("/admin/").status_code == 200


def test_a_directory_account_never_becomes_a_local_one_of_the_same_name(ldap_settings):
    local = factories.staff_create("kwon", is_superuser=False)

    client, response = sign_in("kwon")  # the directory's password: not the local one

    assert not signed_in(client)
    local.refresh_from_db()
    assert (local.is_superuser, hasattr(local, "account")) == (False, False)
    assert signed_in(sign_in("kwon", "pw-12345!")[0])  # the local password still works


def test_a_local_account_without_password_is_handed_over_to_the_directory(ldap_settings):
    handed_over = User.objects.create_user("kwon")  # no usable password
    client, _ = sign_in("kwon")

    assert signed_in(client)
    handed_over.refresh_from_db()
    assert handed_over.account.source == Source.LDAP
    assert handed_over.is_superuser  # robot-admins


def test_local_accounts_sign_in_while_the_directory_is_down(ldap_settings):
    ldap_settings.AUTH_LDAP_SERVER_URI = "ldap://127.0.0.1:9"  # nothing listens there
    factories.user_create("nurse-local", "nurse")

    assert signed_in(sign_in("nurse-local", factories.PASSWORD)[0])
    client, response = sign_in("yoon")
    assert response.status_code == 200  # the form again, not an error page
    assert not signed_in(client)


def test_it_signs_in_over_starttls(ldap_settings, sites):
    with Directory([Person("ahn", "Ahn", "Jisu", ["ward-nurses"])], tls=True) as secure:
        for name, value in secure.settings().items():
            setattr(ldap_settings, name, value)

        assert secure.settings()["AUTH_LDAP_START_TLS"]
        assert signed_in(sign_in("ahn")[0])
    assert roles("ahn") == {"nurse"}
