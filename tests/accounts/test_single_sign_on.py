"""Single sign-on with OpenID Connect (mozilla-django-oidc) against a real provider (npm
oidc-provider): the authorization code flow with PKCE, state and nonce, the user and their
roles and sites from the groups claim, the provider's session ended at sign-out."""

from urllib.parse import parse_qs, urlsplit

from django.contrib.auth import get_user_model
from django.core.cache import cache
from django.test import Client

from accounts.choices import Source
from robots.models import SiteMembership
from tests import factories
from tests.oidc_provider import PASSWORD
from tests.signin import provider_sign_in

User = get_user_model()


def start(client: Client, next_url: str = "/fleet/") -> str:
    """Press "Sign in with ...": the URL of the provider's authorization request."""
    response = client.get(f"/oidc/authenticate/?next={next_url}")
    assert response.status_code == 302
    return response["Location"]


def come_back(client: Client, location: str):
    """The browser back at our callback, as the provider sent it."""
    parts = urlsplit(location)
    assert parts.path == "/oidc/callback/"
    return client.get(f"{parts.path}?{parts.query}")


def signed_in(client: Client) -> bool:
    return "_auth_user_id" in client.session


def test_it_signs_in_an_operator_with_the_provider(sso_settings, sites):
    client = Client()
    authorization = start(client)
    query = parse_qs(urlsplit(authorization).query)
    assert query["code_challenge_method"] == ["S256"]  # PKCE
    assert query["state"]
    assert query["nonce"]

    response = come_back(client, provider_sign_in(authorization, "song", PASSWORD))

    assert response.status_code == 302
    assert response["Location"] == "/fleet/"
    assert signed_in(client)
    user = User.objects.get(username="song")
    assert (user.first_name, user.last_name, user.email) == ("Song", "Hyejin", "song@hospital.test")
    assert (user.account.source, user.account.subject) == (Source.OIDC, "a1f3-operator-song")
    assert set(user.groups.values_list("name", flat=True)) == {"operator"}
    assert list(SiteMembership.objects.filter(user=user).values_list("site__code", flat=True)) == [
        "other"
    ]
    assert client.get("/fleet/?site=other").status_code == 200
    assert client.get("/fleet/?site=tiny").status_code == 404  # not her site


def test_the_same_person_is_found_by_subject_at_the_next_sign_in(sso_settings, sites):
    for _ in range(2):
        client = Client()
        come_back(client, provider_sign_in(start(client), "moon", PASSWORD))
        assert signed_in(client)

    assert User.objects.filter(account__subject="b2e4-nurse-moon").count() == 1


def test_a_callback_this_browser_did_not_start_is_refused(sso_settings, sites):
    attacker, victim = Client(), Client()
    location = provider_sign_in(start(attacker), "moon", PASSWORD)
    victim.get("/oidc/authenticate/")  # the victim has sign-in states of her own

    response = come_back(victim, location)  # a login CSRF: the state is not hers

    assert response.status_code == 400
    assert not signed_in(victim)
    assert not User.objects.filter(username="moon").exists()


def test_a_code_without_its_pkce_verifier_is_refused_by_the_provider(sso_settings, sites):
    client = Client()
    location = provider_sign_in(start(client), "moon", PASSWORD)
    session = client.session
    for entry in session["oidc_states"].values():
        entry["code_verifier"] = "x" * 64  # not the one the challenge was made from
    session.save()

    response = come_back(client, location)

    assert response.status_code == 302
    assert response["Location"] == "/accounts/login/"
    assert not signed_in(client)
    page = client.get("/accounts/login/").content.decode()
    assert "Signing in with Test ID did not succeed" in page


def test_signing_out_ends_the_provider_session(sso_settings, sites):
    client = Client()
    come_back(client, provider_sign_in(start(client), "moon", PASSWORD))

    response = client.post("/accounts/logout/")

    end = urlsplit(response["Location"])
    assert f"{end.scheme}://{end.netloc}" == sso_settings.OIDC_ISSUER
    assert end.path == "/session/end"
    query = parse_qs(end.query)
    assert query["post_logout_redirect_uri"] == ["http://testserver/accounts/login/"]
    assert query["id_token_hint"]
    assert not signed_in(client)


def test_a_local_user_signs_out_locally(sso_settings, sites):
    client = Client()
    user = factories.user_create("kim", "nurse")
    client.post("/accounts/login/", {"username": "kim", "password": factories.PASSWORD})
    assert client.session["_auth_user_id"] == str(user.pk)

    response = client.post("/accounts/logout/")

    assert response["Location"] == "/accounts/login/"


def test_the_login_page_offers_the_button(sso_settings):
    page = Client().get("/accounts/login/?next=/fleet/").content.decode()

    assert 'href="/oidc/authenticate/?next=/fleet/"' in page
    assert "Sign in with Test ID" in page


def test_local_accounts_sign_in_while_the_provider_is_down(sso_settings, sites):
    sso_settings.OIDC_ISSUER = "http://127.0.0.1:9"  # nothing listens there
    cache.clear()
    client = Client()

    response = client.get("/oidc/authenticate/")

    assert response["Location"] == "/accounts/login/"
    assert "not possible right now" in client.get("/accounts/login/").content.decode()
    factories.user_create("kim", "nurse")
    client.post("/accounts/login/", {"username": "kim", "password": factories.PASSWORD})
    assert signed_in(client)


def test_without_an_issuer_there_is_no_single_sign_on(db):
    client = Client()

    assert client.get("/oidc/authenticate/").status_code == 404
    assert "Sign in with" not in client.get("/accounts/login/").content.decode()
