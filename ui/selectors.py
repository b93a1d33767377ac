"""Reads that only the pages need: the site a page is about, a robot with its recent history."""

from dataclasses import dataclass

from django.core.exceptions import PermissionDenied
from django.http import Http404

from boards.models import RobotEvent
from robots.membership import sites_of
from robots.models import PresenceChange, Robot, Site
from robots.selectors import sites_all
from scheduling.models import OperatorAction

RECENT_EVENTS = 20
RECENT_PRESENCE = 10
RECENT_ACTIONS = 10


@dataclass(frozen=True)
class RobotDetail:
    robot: Robot
    events: list[RobotEvent]
    presence_changes: list[PresenceChange]
    actions: list[OperatorAction]


def robot_detail(*, code: str) -> RobotDetail | None:
    """A robot with its recent events, presence changes and operator actions (four queries)."""
    robot = Robot.objects.filter(code=code).select_related("site", "dock").first()
    if robot is None:
        return None
    return RobotDetail(
        robot=robot,
        events=list(RobotEvent.objects.filter(robot=robot).order_by("-id")[:RECENT_EVENTS]),
        presence_changes=list(robot.presence_changes.all()[:RECENT_PRESENCE]),
        actions=list(robot.operator_actions.select_related("by", "message")[:RECENT_ACTIONS]),
    )


def page_site(request) -> tuple[Site, list[Site]]:
    """The site a page is about (?site=<code>, else the first) and the user's sites, for a
    choice (robots/membership.py)."""
    every = sites_all()
    if not every:
        raise Http404("no site is loaded yet (manage.py load_site FILE)")
    sites = sites_of(request.user, every)
    if not sites:
        raise PermissionDenied("your account belongs to no site: ask an administrator")
    code = request.POST.get("site") or request.GET.get("site")
    if not code:
        return sites[0], sites
    site = next((each for each in sites if each.code == code), None)
    if site is None:
        raise Http404(f"no site {code!r}")
    return site, sites
