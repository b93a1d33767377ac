"""Reads of the FHIR endpoint. Every read of deliveries, and so of the orders and patients
they are for (patient-linked), goes through `tasks_visible`: one place to audit them."""

from django.db.models import Count, Max, OuterRef, Prefetch, QuerySet, Subquery

from fhir_r4.models import Order
from robots.choices import WaypointKind
from robots.membership import member_site_ids
from robots.models import Robot, Site, Waypoint
from scheduling.models import CustodyEntry, Task, TaskStop, TaskTransition


def tasks_visible(user) -> QuerySet[Task]:
    """The deliveries `user` may read: those of the user's sites (every site for staff)."""
    sites = member_site_ids(user)
    tasks = Task.objects.all()
    return tasks if sites is None else tasks.filter(site_id__in=sites)


def tasks_represented(tasks: QuerySet[Task]) -> QuerySet[Task]:
    """`tasks` with all a FHIR Task shows: its order, stops, custody hand-offs, robot and
    site, its version (history entries), when it last changed, and its newest entries' robot
    event (for businessStatus) and note (for statusReason). Five queries for any number."""
    newest = TaskTransition.objects.filter(task=OuterRef("pk")).order_by("-id")
    ended = newest.filter(new=OuterRef("status"))
    return (
        tasks.select_related("site", "robot", "fhir_order")
        .prefetch_related(
            Prefetch("stops", queryset=TaskStop.objects.select_related("waypoint")),
            Prefetch("custody", queryset=CustodyEntry.objects.order_by("at", "id")),
        )
        .annotate(
            version=Count("history"),
            last_updated=Max("history__at"),
            newest_event_type=Subquery(newest.values("event__type")[:1]),
            newest_event_stop=Subquery(newest.values("event__stop")[:1]),
            ended_note=Subquery(ended.values("note")[:1]),
        )
    )


def task_visible(user, code: str) -> Task | None:
    """The delivery `code` as a FHIR Task shows it, if `user` may read it."""
    return tasks_represented(tasks_visible(user).with_code(code)).first()


def task_for_webhook(task_id: int) -> Task:
    """A delivery as a FHIR Task shows it, for its site's webhook subscriptions (which see
    every delivery of their site, as the subscribing system does)."""
    return tasks_represented(Task.objects.filter(pk=task_id)).get()


def orders_matching(user, system: str | None, value: str) -> list[Task]:
    """The user's deliveries ordered with this business identifier (system None: any)."""
    orders = Order.objects.filter(identifier_value=value)
    if system is not None:
        orders = orders.filter(identifier_system=system)
    return list(tasks_visible(user).filter(fhir_order__in=orders)[:2])


def order_for_staff(task: Task) -> dict | None:
    """What the pages show of a delivery's order: the order and patient by reference or
    identifier only, and who asked; None if it was not ordered over FHIR."""
    order = Order.objects.filter(task_id=task.pk).first()
    if order is None:
        return None
    return {
        "identifier": order.identifier_value,
        "focus": _minimal(order.focus),
        "beneficiary": _minimal(order.beneficiary),
        "requester": _minimal(order.requester, display=True),
    }


def _minimal(reference: dict | None, *, display: bool = False) -> str:
    if not reference:
        return ""
    identifier = reference.get("identifier") or {}
    parts = [reference.get("reference") or reference.get("type") or ""]
    if identifier.get("value"):
        parts.append(identifier["value"])
    if display and reference.get("display"):
        parts.append(reference["display"])
    return " · ".join(part for part in parts if part)


# --- Locations and Devices -------------------------------------------------------------------


def sites_visible(user) -> QuerySet[Site]:
    sites = member_site_ids(user)
    return Site.objects.all() if sites is None else Site.objects.filter(pk__in=sites)


def stations_visible(user) -> QuerySet[Waypoint]:
    sites = member_site_ids(user)
    stations = Waypoint.objects.filter(kind=WaypointKind.STATION).select_related("site", "floor")
    return stations if sites is None else stations.filter(site_id__in=sites)


def robots_visible(user) -> QuerySet[Robot]:
    sites = member_site_ids(user)
    robots = Robot.objects.select_related("site")
    return robots if sites is None else robots.filter(site_id__in=sites)
