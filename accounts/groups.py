"""Roles and sites from the directory's groups: the ROLE_GROUPS and SITE_GROUPS settings.

Pure Python, so the settings module can parse them at start-up (and refuse to start on a value
that makes no sense) and tests can parse any text.

Both settings are lists of `KEY=GROUP` entries separated by semicolons; a group is an LDAP
group's DN (`cn=ward-nurses,ou=groups,dc=hospital,dc=org`) or a name from the single sign-on
provider's groups claim (`ward-nurses`, `/hospital/ward-nurses`, an Entra ID group's object id).
Only the first `=` of an entry separates its key, so a DN needs no quoting. Groups are compared
without case and without the spaces around a DN's commas, as directories compare DNs.

    ROLE_GROUPS   ROLE=GROUP; ROLE is nurse, operator, admin or auditor; a role may be listed for
                  several groups (any of them gives it).
    SITE_GROUPS   SITE=GROUP (a member of the site) or SITE/STATION=GROUP (a member of the site
                  whose unit is that station, for badge deliveries and workstations).
"""

import re
from dataclasses import dataclass

# accounts.choices.Role's values; not imported, as the settings module reads this file before
# Django is set up.
ROLES = ("nurse", "operator", "admin", "auditor")
SLUG = re.compile(r"^[-a-zA-Z0-9_]+$")
STATION = re.compile(r"^[^\s/=;]+$")


class GroupsSyntaxError(ValueError):
    """A ROLE_GROUPS or SITE_GROUPS value that cannot be read; the message names the entry."""


def group_key(group: str) -> str:
    """How two spellings of one group compare equal: case and spaces around commas ignored."""
    return ",".join(part.strip() for part in group.split(",")).casefold()


@dataclass(frozen=True)
class Place:
    """Where a SITE_GROUPS entry puts its group's members: a site, and a unit (station code)
    there or "" for none."""

    site: str
    unit: str


def _entries(text: str, setting: str) -> list[tuple[str, str]]:
    entries = []
    for raw in text.split(";"):
        entry = raw.strip()
        if not entry:
            continue  # a trailing semicolon, or line breaks between entries
        key, equals, group = entry.partition("=")
        key, group = key.strip(), group.strip()
        if not equals or not key or not group:
            raise GroupsSyntaxError(f"{setting}: {entry!r} is not KEY=GROUP")
        entries.append((key, group))
    return entries


def parse_role_groups(text: str) -> dict[str, frozenset[str]]:
    """ROLE_GROUPS -> {role: keys of the groups that give it}, only the roles it names."""
    roles: dict[str, set[str]] = {}
    for role, group in _entries(text, "ROLE_GROUPS"):
        if role not in ROLES:
            raise GroupsSyntaxError(f"ROLE_GROUPS: {role!r} is not a role (use {', '.join(ROLES)})")
        roles.setdefault(role, set()).add(group_key(group))
    return {role: frozenset(groups) for role, groups in roles.items()}


def parse_site_groups(text: str) -> dict[Place, frozenset[str]]:
    """SITE_GROUPS -> {place: keys of the groups whose members belong there}."""
    places: dict[Place, set[str]] = {}
    units_of: dict[tuple[str, str], str] = {}  # (site, group) -> the unit it gives
    for key, group in _entries(text, "SITE_GROUPS"):
        site, _slash, unit = key.partition("/")
        if not SLUG.match(site) or (_slash and not STATION.match(unit)):
            raise GroupsSyntaxError(f"SITE_GROUPS: {key!r} is not SITE or SITE/STATION")
        gkey = group_key(group)
        if unit:
            other = units_of.setdefault((site, gkey), unit)
            if other != unit:
                raise GroupsSyntaxError(
                    f"SITE_GROUPS: {group!r} gives two units of {site}: {other} and {unit}"
                )
        places.setdefault(Place(site=site, unit=unit), set()).add(gkey)
    return {place: frozenset(groups) for place, groups in places.items()}


def roles_of_groups(groups, role_groups: dict[str, frozenset[str]]) -> set[str]:
    """The roles the groups give (of those ROLE_GROUPS names)."""
    keys = {group_key(group) for group in groups}
    return {role for role, given_by in role_groups.items() if keys & given_by}


def memberships_of_groups(
    groups, site_groups: dict[Place, frozenset[str]]
) -> dict[str, str | None]:
    """{site code: unit} for the sites the groups make the user a member of: the unit's station
    code, "" for none, or None where SITE_GROUPS names no unit of that site (an administrator
    sets it). A unit's group makes its members members of the site too; of two unit groups of
    one site, the first listed wins."""
    keys = {group_key(group) for group in groups}
    units_managed = managed_sites(site_groups)
    found: dict[str, str | None] = {}
    for place, given_by in site_groups.items():  # in the order of the setting
        if not keys & given_by:
            continue
        if place.unit and not found.get(place.site):
            found[place.site] = place.unit
        else:
            found.setdefault(place.site, "" if units_managed[place.site] else None)
    return found


def managed_sites(site_groups: dict[Place, frozenset[str]]) -> dict[str, bool]:
    """{site code: whether its unit is managed too} for every site SITE_GROUPS names."""
    managed: dict[str, bool] = {}
    for place in site_groups:
        managed[place.site] = managed.get(place.site, False) or bool(place.unit)
    return managed
