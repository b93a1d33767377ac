"""The PIN of a secure delivery: shown once to its requester, never stored or sent in clear.

The robot must check a PIN at the drop-off even in a Wi-Fi dead zone, so its plan carries a
salted slow hash (PBKDF2-HMAC-SHA256, a salt and an iteration count of the delivery's own) and
the robot compares the hash of what is typed (docs/robot-protocol.md, "Secure deliveries").
A robot, or anyone reading its board, learns nothing that opens another delivery.
"""

import hmac
import secrets
from dataclasses import dataclass

from core.tokens import secret_digest

ALGORITHM = "pbkdf2_sha256"
ITERATIONS = 120_000  # tens of milliseconds on a robot's CPU per attempt; attempts are few
PIN_DIGITS = 6


@dataclass(frozen=True)
class PinHash:
    salt: str  # hex
    iterations: int
    hash: str  # hex

    def wire(self) -> dict:
        """What a plan carries for the robot to check a PIN offline."""
        return {
            "algorithm": ALGORITHM,
            "iterations": self.iterations,
            "salt": self.salt,
            "hash": self.hash,
        }


def pin_new() -> str:
    return "".join(secrets.choice("0123456789") for _ in range(PIN_DIGITS))


def pin_hash(pin: str, *, salt: str | None = None, iterations: int = ITERATIONS) -> PinHash:
    salt = salt or secrets.token_hex(16)
    digest = secret_digest(pin, salt=salt, iterations=iterations)
    return PinHash(salt=salt, iterations=iterations, hash=digest)


def pin_matches(pin: str, hashed: PinHash) -> bool:
    tried = pin_hash(pin, salt=hashed.salt, iterations=hashed.iterations)
    return hmac.compare_digest(tried.hash, hashed.hash)
