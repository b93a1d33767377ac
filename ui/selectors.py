"""Reads that only the pages need: the site a page is about, a robot with its recent history."""

from dataclasses import dataclass

from boards.models import RobotEvent
from robots.membership import site_chosen
from robots.models import PresenceChange, Robot, Site
from scheduling.models import OperatorAction, Task

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
    return site_chosen(request.user, request.POST.get("site") or request.GET.get("site"))


def tasks_by_pk(pks: list[int], *, site: Site) -> list[Task]:
    """The site's tasks of these ids, newest first, with their requesters (one query)."""
    tasks = Task.objects.filter(pk__in=pks, site=site).select_related("requester")
    return list(tasks.order_by("-pk"))
