"""Bearer tokens for robots and API users. Only a hash is ever stored."""

import hashlib
import secrets


def token_hash(token: str) -> str:
    # Tokens are 256 random bits, so a fast unsalted hash is enough: there is nothing to guess.
    return hashlib.sha256(token.encode()).hexdigest()


def token_new() -> tuple[str, str]:
    """A fresh token and its hash; show the token once and store the hash."""
    token = secrets.token_urlsafe(32)
    return token, token_hash(token)


def bearer_token(authorization_header: str | None) -> str | None:
    if not authorization_header:
        return None
    scheme, _, value = authorization_header.partition(" ")
    if scheme.lower() != "bearer" or not value.strip():
        return None
    return value.strip()
