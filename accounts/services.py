"""Writes of the sign-in: a directory user's roles and sites from their groups at each sign-in,
and a person's workstation PIN."""

import logging
import re

from django.conf import settings
from django.contrib.auth.hashers import make_password
from django.contrib.auth.models import Group
from django.core.exceptions import ValidationError
from django.db import transaction
from django.utils import timezone

from accounts.choices import Role, Source
from accounts.groups import memberships_of_groups, roles_of_groups
from accounts.models import Account
from robots.choices import WaypointKind
from robots.models import Site, SiteMembership, Waypoint

logger = logging.getLogger(__name__)

PIN_PATTERN = re.compile(r"^[0-9]{4,8}$")


class AccountConflict(Exception):
    """A directory sign-in that would take over another user: refused, and logged."""


def account_claimable(user, source: str) -> bool:
    """May a sign-in from `source` (LDAP, single sign-on) act as this existing user? Its own
    users, yes; a local user only without a usable password (an administrator handed the
    account over to the directory by removing its password), so that a directory account named
    like a local administrator never becomes that administrator."""
    account = Account.objects.filter(user=user).first()
    if account is not None and account.source != Source.LOCAL:
        return account.source == source
    return not user.has_usable_password()


@transaction.atomic
def account_sync(*, user, source: str, subject: str, groups, now=None) -> Account:
    """Record where the user signed in from, then set the roles and site memberships the
    directory's groups give (ROLE_GROUPS, SITE_GROUPS): only those the settings name, so an
    administrator's choices about the others stay. Called at each sign-in, so a user removed
    from a group loses what it gave at their next one."""
    taken = Account.objects.filter(source=source, subject=subject).exclude(user=user)
    if subject and taken.exists():
        raise AccountConflict(f"{source} subject {subject!r} already belongs to another user")
    account, _created = Account.objects.update_or_create(
        user=user,
        defaults={"source": source, "subject": subject, "synced_at": now or timezone.now()},
    )
    groups = list(groups)
    _roles_apply(user, roles_of_groups(groups, settings.ROLE_GROUPS))
    _memberships_apply(user, memberships_of_groups(groups, settings.SITE_GROUPS))
    return account


def _roles_apply(user, roles: set[str]) -> None:
    managed = set(settings.ROLE_GROUPS)
    for role in managed & {Role.NURSE, Role.OPERATOR, Role.AUDITOR}:
        group, _created = Group.objects.get_or_create(name=role)
        if role in roles:
            user.groups.add(group)
        else:
            user.groups.remove(group)
    if Role.ADMIN in managed:
        user.is_staff = user.is_superuser = Role.ADMIN in roles
        user.save(update_fields=["is_staff", "is_superuser"])
    for cached in ("_page_roles", "_member_site_ids"):  # core.access, robots.membership
        user.__dict__.pop(cached, None)


def _memberships_apply(user, wanted: dict[str, str | None]) -> None:
    managed = {place.site for place in settings.SITE_GROUPS}
    if not managed:
        return
    sites = {site.code: site for site in Site.objects.filter(code__in=managed)}
    for code in managed - set(sites):
        logger.warning("SITE_GROUPS names site %r, which is not loaded", code)
    current = {
        m.site_id: m for m in SiteMembership.objects.filter(user=user, site__in=sites.values())
    }
    for code, site in sites.items():
        membership = current.get(site.pk)
        if code not in wanted:
            if membership is not None:
                membership.delete()
            continue
        unit = _unit(site, wanted[code])
        if membership is None:
            SiteMembership.objects.create(user=user, site=site, unit=unit or None)
        elif unit is not None and membership.unit_id != (unit.pk if unit else None):
            membership.unit = unit or None
            membership.save(update_fields=["unit"])


def _unit(site: Site, code: str | None):
    """The unit's station (a Waypoint), "" for none, None where the unit is not managed."""
    if not code:
        return code
    station = Waypoint.objects.filter(site=site, code=code, kind=WaypointKind.STATION).first()
    if station is None:
        logger.warning("SITE_GROUPS names station %r, which site %s does not have", code, site)
        return None
    return station


def pin_validate(pin: str) -> None:
    """A workstation PIN: 4 to 8 digits, not one digit repeated nor a run (1234, 9876)."""
    if not PIN_PATTERN.match(pin):
        raise ValidationError({"pin": "Use 4 to 8 digits."})
    steps = {int(b) - int(a) for a, b in zip(pin, pin[1:], strict=False)}
    if len(steps) == 1 and steps <= {-1, 0, 1}:
        raise ValidationError({"pin": "This PIN is too easy to guess: choose another one."})


@transaction.atomic
def account_pin_set(*, user, pin: str) -> None:
    """Keep the salted slow hash of the user's workstation PIN (never the PIN), or forget it
    ("")."""
    if pin:
        pin_validate(pin)
    account, _created = Account.objects.get_or_create(user=user)
    account.pin_hash = make_password(pin) if pin else ""
    account.save(update_fields=["pin_hash"])
