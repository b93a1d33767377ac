"""Staff badges, kept and sent only as salted slow hashes.

A robot at a secure drop-off may be in a Wi-Fi dead zone, so it must tell by itself whether a
badge held to its reader belongs to a user of the receiving unit. Its plan therefore carries,
for each such user, a PBKDF2-HMAC-SHA256 hash of the badge id with a salt and an iteration
count of that user's own (as a delivery's PIN: scheduling/pins.py); the robot hashes what it
reads the same way and compares. The badge id itself is never stored nor sent.
"""

import hmac
import secrets
from dataclasses import dataclass

from core.tokens import secret_digest

ALGORITHM = "pbkdf2_sha256"
# Fewer than a PIN's: a robot checks a read badge against each user of the unit in turn, and
# badge ids are far longer than a 6-digit PIN.
ITERATIONS = 20_000


@dataclass(frozen=True)
class BadgeHash:
    salt: str  # hex
    iterations: int
    hash: str  # hex

    def wire(self, holder: str) -> dict:
        """What a plan carries for the robot to recognise the badge offline, and name it."""
        return {
            "holder": holder,
            "algorithm": ALGORITHM,
            "iterations": self.iterations,
            "salt": self.salt,
            "hash": self.hash,
        }


def badge_hash(badge: str, *, salt: str | None = None, iterations: int = ITERATIONS) -> BadgeHash:
    salt = salt or secrets.token_hex(16)
    digest = secret_digest(badge, salt=salt, iterations=iterations)
    return BadgeHash(salt=salt, iterations=iterations, hash=digest)


def badge_matches(badge: str, hashed: BadgeHash) -> bool:
    tried = badge_hash(badge, salt=hashed.salt, iterations=hashed.iterations)
    return hmac.compare_digest(tried.hash, hashed.hash)
