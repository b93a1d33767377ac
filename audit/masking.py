"""How masked fields (secrets and their hashes) appear in an entry's before/after."""

MASK = "(secret)"


def secret_masked(value) -> str:
    """Nothing of the secret, not even a part: only whether it was set, and that it changed."""
    return MASK if value and value != "None" else ""
