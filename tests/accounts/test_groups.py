"""ROLE_GROUPS and SITE_GROUPS: read strictly, and which roles and sites groups give."""

import re

import pytest

from accounts.groups import (
    GroupsSyntaxError,
    Place,
    memberships_of_groups,
    parse_role_groups,
    parse_site_groups,
    roles_of_groups,
)

NURSES = "CN=Ward Nurses, OU=Groups,DC=hospital,DC=org"


def test_a_dn_needs_no_quoting_and_compares_as_directories_compare_dns():
    roles = parse_role_groups(f"nurse={NURSES};\n operator=fleet-operators ; nurse=/nurses;")

    assert roles_of_groups(["cn=ward nurses,ou=groups,dc=hospital,dc=org"], roles) == {"nurse"}
    assert roles_of_groups(["/nurses", "Fleet-Operators"], roles) == {"nurse", "operator"}
    assert roles_of_groups(["cn=other,ou=groups,dc=hospital,dc=org"], roles) == set()


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("nurse", "'nurse' is not KEY=GROUP"),
        ("nurse=", "'nurse=' is not KEY=GROUP"),
        ("=cn=x", "'=cn=x' is not KEY=GROUP"),
        ("doctor=cn=x", re.escape("'doctor' is not a role (use nurse, operator, admin, auditor)")),
    ],
)
def test_role_groups_it_cannot_read_are_refused_naming_the_entry(text, error):
    with pytest.raises(GroupsSyntaxError, match=error):
        parse_role_groups(text)


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("tiny", "'tiny' is not KEY=GROUP"),
        ("ti ny=cn=x", "'ti ny' is not SITE or SITE/STATION"),
        ("tiny/=cn=x", "'tiny/' is not SITE or SITE/STATION"),
        ("tiny/A=g;tiny/B=g", "'g' gives two units of tiny: A and B"),
    ],
)
def test_site_groups_it_cannot_read_are_refused_naming_the_entry(text, error):
    with pytest.raises(GroupsSyntaxError, match=error):
        parse_site_groups(text)


def test_a_units_group_makes_its_members_members_of_the_site_with_that_unit():
    places = parse_site_groups("tiny=staff; tiny/3F-WARD=ward-3; tiny/1F-PHARM=pharmacy; other=o")

    assert Place("tiny", "3F-WARD") in places
    assert memberships_of_groups(["staff"], places) == {"tiny": ""}  # a unit, but none of these
    assert memberships_of_groups(["ward-3"], places) == {"tiny": "3F-WARD"}
    assert memberships_of_groups(["pharmacy", "ward-3"], places) == {"tiny": "3F-WARD"}  # first
    assert memberships_of_groups(["o"], places) == {"other": None}  # no unit named: left alone
    assert memberships_of_groups([], places) == {}
