"""Bearer tokens for robots and API users. Only a hash is ever stored."""

import hashlib
import secrets


def token_hash(token: str) -> str:
    # Tokens are 256 random bits, so a fast unsalted hash is enough: there is nothing to guess.
    return hashlib.sha256(token.encode()).hexdigest()


def secret_digest(secret: str, *, salt: str, iterations: int) -> str:
    """PBKDF2-SHA256 of a short secret a person types or shows (a PIN, a badge), hex; guessable
    secrets, so salted and slow, unlike tokens. Robots check it offline with the same inputs."""
    return hashlib.pbkdf2_hmac("sha256", secret.encode(), bytes.fromhex(salt), iterations).hex()


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
