"""OpenID Connect single sign-on (mozilla-django-oidc): the provider's endpoints by discovery
from OIDC_ISSUER, and the end of the provider's session at sign-out.

The endpoints are read from `<issuer>/.well-known/openid-configuration` when a sign-in first
needs them and kept for an hour, never at start-up: a provider that is down must not keep the
server, or the local break-glass accounts, from working.
"""

import logging
from urllib.parse import urlencode, urlsplit

import requests
from django.conf import settings
from django.contrib.auth import BACKEND_SESSION_KEY
from django.core.cache import cache
from django.urls import reverse

logger = logging.getLogger(__name__)

BACKEND = "accounts.backends.SingleSignOnBackend"
METADATA_SECONDS = 3600
ID_TOKEN_SESSION_KEY = "oidc_id_token"  # where mozilla-django-oidc keeps it (OIDC_STORE_ID_TOKEN)


class ProviderUnavailable(Exception):
    """The provider's discovery document could not be read, or names another issuer."""


def enabled() -> bool:
    return bool(settings.OIDC_ISSUER)


def unavailable_message() -> str:
    return (
        f"Signing in with {settings.OIDC_PROVIDER_NAME} is not possible right now: try again "
        "later, or ask the IT service desk."
    )


def failed_message() -> str:
    return f"Signing in with {settings.OIDC_PROVIDER_NAME} did not succeed: please try again."


def provider_metadata() -> dict:
    """The provider's discovery document (cached per process)."""
    key = f"oidc-metadata:{settings.OIDC_ISSUER}"
    metadata = cache.get(key)
    if metadata is not None:
        return metadata
    url = settings.OIDC_ISSUER.rstrip("/") + "/.well-known/openid-configuration"
    try:
        response = requests.get(url, timeout=settings.OIDC_TIMEOUT)
        response.raise_for_status()
        metadata = response.json()
    except (requests.RequestException, ValueError) as exc:
        raise ProviderUnavailable(f"{url}: {exc}") from exc
    # OpenID Connect Discovery 1.0, 4.3: the document must name the issuer it was asked for.
    if not isinstance(metadata, dict) or metadata.get("issuer", "").rstrip("/") != (
        settings.OIDC_ISSUER.rstrip("/")
    ):
        raise ProviderUnavailable(f"{url} names another issuer")
    missing = {"authorization_endpoint", "token_endpoint", "jwks_uri"} - set(metadata)
    if missing:
        raise ProviderUnavailable(f"{url} lacks {', '.join(sorted(missing))}")
    cache.set(key, metadata, METADATA_SECONDS)
    return metadata


def provider_origin() -> str:
    """scheme://host[:port] of the issuer (the sign-out form's redirect goes there)."""
    parts = urlsplit(settings.OIDC_ISSUER)
    return f"{parts.scheme}://{parts.netloc}"


def end_session_url(request) -> str | None:
    """Where to send a user who signed in with single sign-on and signs out, so the provider's
    session ends too (OpenID Connect RP-Initiated Logout), coming back to the login page; None
    for other users, or when the provider offers no end_session_endpoint."""
    if not enabled() or request.session.get(BACKEND_SESSION_KEY) != BACKEND:
        return None
    try:
        endpoint = provider_metadata().get("end_session_endpoint")
    except ProviderUnavailable as exc:
        logger.warning("single sign-on: the provider's session is not ended: %s", exc)
        return None
    if not endpoint:
        return None
    params = {
        "client_id": settings.OIDC_RP_CLIENT_ID,
        "post_logout_redirect_uri": request.build_absolute_uri(reverse("login")),
    }
    id_token = request.session.get(ID_TOKEN_SESSION_KEY)
    if id_token:
        params["id_token_hint"] = id_token
    separator = "&" if "?" in endpoint else "?"
    return f"{endpoint}{separator}{urlencode(params)}"
