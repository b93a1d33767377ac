"""The PIN of a secure delivery: never stored or sent in clear.

The robot must check a PIN at the drop-off even in a Wi-Fi dead zone, so its plan carries a
salted slow hash (PBKDF2-HMAC-SHA256, a salt and an iteration count of the delivery's own) and
the robot compares the hash of what is typed (docs/robot-protocol.md, "Secure deliveries").
A robot, or anyone reading its board, learns nothing that opens another delivery.

Whoever reads a robot's storage can still guess a PIN offline against its hash, so the PIN's
length and the iterations make that slow (docs/deployment/security.md, "PINs"): eight digits
(settings.SECURE_PIN_DIGITS) and 600,000 iterations (what OWASP asks of PBKDF2-HMAC-SHA256)
cost an attacker months of CPU per PIN, and the robot a fraction of a second per attempt.
Both are within the documented scheme (the plan says the iterations, and the digits too).

The recipient must learn the PIN the way the hospital chooses, so the server also keeps it
sealed (Fernet: AES-128-CBC with an HMAC-SHA256, from the well-kept `cryptography` package)
under a key derived from SECRET_KEY: shown again on the delivery's page to its requester and on
the receiving station's page to its signed-in staff while the delivery is on its way, never in
a log, a live event or a robot's plan.
"""

import base64
import hashlib
import hmac
import secrets
from dataclasses import dataclass

from cryptography.fernet import Fernet, InvalidToken
from django.conf import settings

from core.tokens import secret_digest

ALGORITHM = "pbkdf2_sha256"
ITERATIONS = 600_000


@dataclass(frozen=True)
class PinHash:
    salt: str  # hex
    iterations: int
    hash: str  # hex
    digits: int = 0  # the PIN's length; 0 for deliveries made before it was kept

    def wire(self) -> dict:
        """What a plan carries for the robot to check a PIN offline."""
        wire = {
            "algorithm": ALGORITHM,
            "iterations": self.iterations,
            "salt": self.salt,
            "hash": self.hash,
        }
        if self.digits:
            wire["digits"] = self.digits
        return wire


def pin_new() -> str:
    return "".join(secrets.choice("0123456789") for _ in range(settings.SECURE_PIN_DIGITS))


def pin_hash(pin: str, *, salt: str | None = None, iterations: int = ITERATIONS) -> PinHash:
    salt = salt or secrets.token_hex(16)
    digest = secret_digest(pin, salt=salt, iterations=iterations)
    return PinHash(salt=salt, iterations=iterations, hash=digest, digits=len(pin))


def pin_matches(pin: str, hashed: PinHash) -> bool:
    tried = pin_hash(pin, salt=hashed.salt, iterations=hashed.iterations)
    return hmac.compare_digest(tried.hash, hashed.hash)


def pin_seal(pin: str) -> str:
    return _fernet().encrypt(pin.encode()).decode()


def pin_unseal(sealed: str) -> str | None:
    """The sealed PIN, or None when it cannot be opened (SECRET_KEY changed since)."""
    try:
        return _fernet().decrypt(sealed.encode()).decode()
    except InvalidToken:
        return None


def _fernet() -> Fernet:
    # A key of its own: the PINs' seal is not the key that signs sessions.
    key = hashlib.sha256(b"hospital_delivery:secure-delivery-pin:" + settings.SECRET_KEY.encode())
    return Fernet(base64.urlsafe_b64encode(key.digest()))
