"""Reads that only the pages need: the site a page is about, a robot with its recent history."""

from dataclasses import dataclass

from accounts.models import Workstation
from boards.models import RobotEvent
from robots.membership import site_chosen
from robots.models import PresenceChange, Robot, Site, SiteMembership
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


def user_unit_ids(user, site: Site) -> set[int]:
    """The stations of the units the user works at on the site: their membership's, and, for a
    shared ward workstation's account, its own (two small queries)."""
    if not user.is_authenticated:
        return set()
    memberships = SiteMembership.objects.filter(user=user, site=site, unit__isnull=False)
    workstations = Workstation.objects.filter(user=user, site=site)
    return {*memberships.values_list("unit_id", flat=True)} | {
        *workstations.values_list("unit_id", flat=True)
    }


def pin_for_requester(task: Task, user) -> str | None:
    """A secure delivery's PIN for its delivery page: to whoever ordered it, while on its way."""
    return task.pin_to_hand_on() if user.pk == task.requester_id else None


def pin_for_station(task: Task, user, *, unit_staff: bool) -> str | None:
    """A secure delivery's PIN on its receiving station's page: to that unit's staff signed in
    (`unit_staff`: the station is one of user_unit_ids) and to whoever ordered it; nobody else,
    operators and other units included."""
    if not (unit_staff or user.pk == task.requester_id):
        return None
    return task.pin_to_hand_on()
