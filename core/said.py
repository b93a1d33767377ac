"""Words said to people later, in whichever language they read: a message kept as its English
msgid and its values (`Said("%(robot)s went offline", robot="R1")`), rendered when shown, in
the reader's language. A value may itself be Said, rendered in the same language. Stored as
JSON beside the English text, which the API, webhooks and logs keep using.

Mark each msgid with gettext_noop where it is written, so makemessages finds it."""

from dataclasses import dataclass, field

from django.utils import translation


@dataclass(frozen=True)
class Said:
    msgid: str
    values: dict = field(default_factory=dict)

    def __init__(self, msgid: str, **values):
        object.__setattr__(self, "msgid", msgid)
        object.__setattr__(self, "values", values)

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
