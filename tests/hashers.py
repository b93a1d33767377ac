"""The tests' password hasher: Django's PBKDF2-SHA256 with few iterations."""

from django.contrib.auth.hashers import PBKDF2PasswordHasher


class QuickPBKDF2PasswordHasher(PBKDF2PasswordHasher):
    """Django's hasher with a thousand iterations instead of its million, which cost more than
    a CPU-second for every user a test makes. The algorithm's name is the same and each hash
    records its iteration count, so a server the tests start as a subprocess, with the
    project's settings, checks these hashes too (and hashes one again at full strength on its
    first sign-in there, as Django does whenever the count rises)."""

    iterations = 1_000
