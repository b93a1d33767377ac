"""Public codes made of a prefix and a row's primary key: T-0042, m-195, l-7.

Parsed by an exact pattern: ASCII digits only (str.isdigit() also accepts "²", which int()
refuses) and a number the database can hold (a bigint), so a hostile code is simply unknown.
"""

import re

MAX_PK = 2**63 - 1
_DIGITS = re.compile(r"[0-9]{1,19}")


def code_pk(code: str, prefix: str) -> int | None:
    """The primary key in `code` (prefix then digits), or None if it is not such a code."""
    if not isinstance(code, str) or not code.startswith(prefix):
        return None
    digits = code[len(prefix) :]
    if not _DIGITS.fullmatch(digits):
        return None
    pk = int(digits)
    return pk if 0 < pk <= MAX_PK else None
