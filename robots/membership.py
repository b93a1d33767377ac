"""Which sites a user may see and act on: the sites of their SiteMembership rows, or every site
for staff users and superusers (administrators).

Pages, the live state, the sites' websockets and the API's actions all ask here; what a user
may not see answers 404 (as if it did not exist), a page about no site of theirs 403.
"""

from django.core.exceptions import PermissionDenied
from django.http import Http404

from robots.models import Site, SiteMembership


def member_site_ids(user) -> frozenset[int] | None:
    """The ids of the user's sites, or None for every site (read once per request)."""
    if user.is_staff or user.is_superuser:
        return None
    ids = getattr(user, "_member_site_ids", None)
    if ids is None:
        rows = SiteMembership.objects.filter(user_id=user.pk).values_list("site_id", flat=True)
        ids = user._member_site_ids = frozenset(rows)
    return ids


def member_site_codes(user) -> frozenset[str] | None:
    """The codes of the user's sites, or None for every site."""
    ids = member_site_ids(user)
    if ids is None:
        return None
    return frozenset(Site.objects.filter(pk__in=ids).values_list("code", flat=True))


def may_see_site(user, site_id: int) -> bool:
    if not user.is_authenticated:
        return False
    ids = member_site_ids(user)
    return ids is None or site_id in ids


def site_required(user, site_id: int, what: str) -> None:
    """Http404 unless the user may see the site of `what` (so it seems not to exist)."""
    if not may_see_site(user, site_id):
        raise Http404(f"no {what}")


def sites_of(user, sites: list) -> list:
    """`sites` narrowed to those the user may see."""
    ids = member_site_ids(user)
    return list(sites) if ids is None else [site for site in sites if site.pk in ids]


def site_chosen(user, code: str | None) -> tuple[Site, list[Site]]:
    """The site a page is about (`code`, else the user's first) and the user's sites: Http404
    for a site that is not theirs or does not exist, PermissionDenied if they have none."""
    every = list(Site.objects.order_by("code"))
    if not every:
        raise Http404("no site is loaded yet (manage.py load_site FILE)")
    sites = sites_of(user, every)
    if not sites:
        raise PermissionDenied("your account belongs to no site: ask an administrator")
    if not code:
        return sites[0], sites
    site = next((each for each in sites if each.code == code), None)
    if site is None:
        raise Http404(f"no site {code!r}")
    return site, sites
