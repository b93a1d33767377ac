"""Authentication backends of the hospital sign-in (AUTHENTICATION_BACKENDS, settings.py).

- DirectoryBackend: the hospital's LDAP directory or Active Directory (django-auth-ldap).
- SingleSignOnBackend: OpenID Connect (mozilla-django-oidc), from the callback view only.
- BadgePinBackend: a person confirming an order at a shared workstation with badge and PIN.

Each directory sign-in records where the user comes from and applies the roles and sites of
their groups (accounts.services.account_sync). Sign-ins go through Django's authenticate() and
login(), so django-axes throttles them and the user_logged_in / user_login_failed signals tell
of every one.
"""

import logging

import jwt
import requests
from django.conf import settings
from django.contrib.auth import get_user_model
from django.contrib.auth.backends import BaseBackend
from django.contrib.auth.validators import UnicodeUsernameValidator
from django.core.exceptions import SuspiciousOperation, ValidationError
from django_auth_ldap.backend import LDAPBackend
from mozilla_django_oidc.auth import OIDCAuthenticationBackend

from accounts import oidc
from accounts.choices import Source
from accounts.models import Account
from accounts.services import AccountConflict, account_claimable, account_sync

logger = logging.getLogger(__name__)


class DirectoryBackend(LDAPBackend):
    """LDAP / Active Directory: the password is checked by binding as the user found with
    AUTH_LDAP_USER_SEARCH; names and email come from the entry, roles and sites from the groups
    AUTH_LDAP_GROUP_SEARCH finds. A disabled account cannot bind, so it cannot sign in."""

    def authenticate(self, request, username=None, password=None, **kwargs):
        if not username or not password:
            return None
        existing = get_user_model().objects.filter(username__iexact=username.strip()).first()
        if existing is not None and not account_claimable(existing, Source.LDAP):
            return (
                None  # a local account (ModelBackend checks its password) or a single sign-on one
            )
        return super().authenticate(request, username=username, password=password, **kwargs)

    def authenticate_ldap_user(self, ldap_user, password):
        user = super().authenticate_ldap_user(ldap_user, password)
        if user is None:
            return None
        groups = ldap_user.group_dns if settings.AUTH_LDAP_GROUP_SEARCH is not None else ()
        try:
            account_sync(user=user, source=Source.LDAP, subject=ldap_user.dn, groups=groups)
        except AccountConflict as conflict:
            logger.warning("directory sign-in of %s refused: %s", user.get_username(), conflict)
            return None
        return user


class SingleSignOnBackend(OIDCAuthenticationBackend):
    """OpenID Connect: the authorization code (with PKCE) is exchanged at the provider's token
    endpoint, the ID token's signature (the provider's JWKS), nonce, issuer and audience are
    checked, and the user is found by the `sub` claim. The groups claim (OIDC_GROUPS_CLAIM) is
    read from the ID token and the userinfo answer together: Entra ID puts it in the ID token
    only."""

    def __init__(self, *args, **kwargs):
        # mozilla-django-oidc reads the provider's endpoints here; they come from discovery when
        # a sign-in needs them (authenticate), as Django makes a backend for every sign-in.
        self.OIDC_RP_CLIENT_ID = settings.OIDC_RP_CLIENT_ID
        self.OIDC_RP_CLIENT_SECRET = settings.OIDC_RP_CLIENT_SECRET
        self.OIDC_RP_SIGN_ALGO = settings.OIDC_RP_SIGN_ALGO
        self.OIDC_RP_IDP_SIGN_KEY = None
        self.UserModel = get_user_model()

    def authenticate(self, request, **kwargs):
        if "code_verifier" not in kwargs or not oidc.enabled():
            return None  # only the callback view signs in with single sign-on
        try:
            metadata = oidc.provider_metadata()
            self.OIDC_OP_TOKEN_ENDPOINT = metadata["token_endpoint"]
            self.OIDC_OP_USER_ENDPOINT = metadata.get("userinfo_endpoint")
            self.OIDC_OP_JWKS_ENDPOINT = metadata["jwks_uri"]
            self.issuer = metadata["issuer"]
            return super().authenticate(request, **kwargs)
        except (
            oidc.ProviderUnavailable,
            requests.RequestException,
            SuspiciousOperation,
            jwt.InvalidTokenError,
            AccountConflict,
        ) as refused:
            logger.warning("single sign-on refused: %s", refused)
            return None

    def verify_token(self, token, **kwargs):
        payload = super().verify_token(token, **kwargs)
        audience = payload.get("aud")
        audiences = [audience] if isinstance(audience, str) else list(audience or [])
        if payload.get("iss") != self.issuer:
            raise SuspiciousOperation("the ID token is from another issuer")
        if self.OIDC_RP_CLIENT_ID not in audiences:
            raise SuspiciousOperation("the ID token is for another client")
        return payload

    def get_userinfo(self, access_token, id_token, payload):
        if not self.OIDC_OP_USER_ENDPOINT:
            return dict(payload)
        return {**payload, **super().get_userinfo(access_token, id_token, payload)}

    def verify_claims(self, claims):
        return bool(claims.get("sub")) and bool(claims.get(settings.OIDC_USERNAME_CLAIM))

    def filter_users_by_claims(self, claims):
        return self.UserModel.objects.filter(
            account__source=Source.OIDC, account__subject=claims["sub"]
        )

    def create_user(self, claims):
        username = str(claims[settings.OIDC_USERNAME_CLAIM])[:150]
        try:
            UnicodeUsernameValidator()(username)
        except ValidationError as invalid:
            raise AccountConflict(f"{username!r} cannot be a username") from invalid
        existing = self.UserModel.objects.filter(username__iexact=username).first()
        if existing is not None and not account_claimable(existing, Source.OIDC):
            raise AccountConflict(f"username {username!r} is taken by another account")
        user = existing or self.UserModel.objects.create_user(username)
        return self.update_user(user, claims)

    def update_user(self, user, claims):
        user.first_name = str(claims.get("given_name", user.first_name))[:150]
        user.last_name = str(claims.get("family_name", user.last_name))[:150]
        user.email = str(claims.get("email", user.email))[:254]
        user.save(update_fields=["first_name", "last_name", "email"])
        groups = claims.get(settings.OIDC_GROUPS_CLAIM) or []
        groups = [groups] if isinstance(groups, str) else [str(group) for group in groups]
        account_sync(user=user, source=Source.OIDC, subject=claims["sub"], groups=groups)
        return user


class BadgePinBackend(BaseBackend):
    """A person at a shared workstation: `username` is the badge's holder (found by
    accounts.workstations.badge_holder) and `pin_secret` their PIN (so named that Django masks
    it in the user_login_failed signal). It never signs anyone in: get_user answers nothing, so
    no session can rest on it."""

    def authenticate(self, request, username=None, pin_secret=None, workstation=None, **kwargs):
        if username is None or pin_secret is None or workstation is None:
            return None
        account = (
            Account.objects.filter(user__username=username, user__is_active=True)
            .select_related("user")
            .first()
        )
        if account is None or not account.pin_matches(pin_secret):
            return None
        return account.user
