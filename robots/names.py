"""The hospital's own words for its places: a floor, a waypoint or a resource may have a name
per language (the site file's `names: {ko: ..., it: ...}`); a page shows the name in its
viewer's language, else the default name, else the code. Codes never change with language."""

from collections.abc import Iterable, Mapping

from django.conf import settings
from django.utils import translation

NAME_LENGTH = 200


def name_for_viewer(names: Mapping[str, str] | Iterable[tuple[str, str]], default: str) -> str:
    """The name in the active language when one is given, else `default`."""
    by_language = dict(names)
    if not by_language:
        return default
    language = translation.get_language() or settings.LANGUAGE_CODE
    return by_language.get(language) or by_language.get(language.split("-")[0]) or default


def names_problem(value) -> str | None:
    """Why a site file's `names` is refused, or None: a mapping of the languages the pages
    speak (settings.LANGUAGES) to names of at most NAME_LENGTH characters."""
    if not isinstance(value, dict):
        return "must be a mapping of language codes to names"
    known = [code for code, _name in settings.LANGUAGES]
    for language, name in value.items():
        if language not in known:
            return f"'{language}' is not a language of the pages (one of {', '.join(known)})"
        if not isinstance(name, str) or not name.strip() or len(name) > NAME_LENGTH:
            return f"{language}: must be a name of 1 to {NAME_LENGTH} characters"
    return None


def place_label(place) -> str:
    """A waypoint's (or resource's) name for the viewer: MapWaypoint, MapResource, or model."""
    return name_for_viewer(place.names, place.name or place.code)


def floor_label(site_map, code: str) -> str:
    """A floor's name for the viewer ("" when it has none)."""
    names = site_map.floor_names_by_language.get(code, ())
    return name_for_viewer(names, site_map.floor_names.get(code, ""))
