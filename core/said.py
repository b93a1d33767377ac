"""Words said to people later, in whichever language they read: a message kept as its English
msgid and its values (`Said("%(robot)s went offline", robot="R1")`), rendered when shown, in
the reader's language. A value may itself be Said, rendered in the same language. Stored as
JSON beside the English text, which the API, webhooks and logs keep using.

Mark each msgid with gettext_noop where it is written, so makemessages finds it."""

import json

from django.utils import translation


class Said:
    """An English msgid and its values; equal (and hashable) by what it says."""

    __slots__ = ("msgid", "values")

    def __init__(self, msgid: str, **values):
        self.msgid = msgid
        self.values = values

    def __eq__(self, other) -> bool:
        return isinstance(other, Said) and self.as_json() == other.as_json()

    def __hash__(self) -> int:
        return hash(json.dumps(self.as_json(), sort_keys=True, default=str))

    def __repr__(self) -> str:
        return f"Said({self.msgid!r}, **{self.values!r})"

    def __str__(self) -> str:
        """In the active language."""
        said = translation.gettext(self.msgid)
        if not self.values:
            return said
        return said % {name: str(value) for name, value in self.values.items()}

    def in_english(self) -> str:
        with translation.override("en"):
            return str(self)

    def as_json(self) -> dict:
        values = {
            name: value.as_json() if isinstance(value, Said) else value
            for name, value in self.values.items()
        }
        return {"msgid": self.msgid, "values": values}

    @classmethod
    def from_json(cls, stored: dict) -> "Said":
        values = {
            name: cls.from_json(value) if isinstance(value, dict) and "msgid" in value else value
            for name, value in stored.get("values", {}).items()
        }
        return cls(stored["msgid"], **values)


def in_english(text: "str | Said") -> str:
    """What is kept for programs and logs: the English of Said words, or the text itself."""
    return text.in_english() if isinstance(text, Said) else text


def words_of(text: "str | Said") -> dict | None:
    """What is stored to say `text` later in any language; None for plain text."""
    return text.as_json() if isinstance(text, Said) else None


def said_text(words: dict | None, english: str) -> str:
    """What stored `words` say in the active language; `english` when there are none."""
    return str(Said.from_json(words)) if words else english
