"""Leases: which robot holds, or waits for, which shared resource (resources/leases.py runs them).

No foreign key to Site on purpose: a lease row is written while its resource row is locked,
and a row referring to the site would wait on the site row (its foreign key check) while a
heartbeat holds that row and waits for the resource.
"""

from datetime import datetime, timedelta

from django.conf import settings
from django.db import models
from django.db.models import Case, Count, OuterRef, Q, Subquery, Value, When
from django.db.models.functions import Coalesce

from core.codes import code_pk
from resources.choices import HOLDING_LEASE_STATES, LIVE_LEASE_STATES, LeaseEndCause, LeaseState
from robots.models import Floor, Resource, Robot

LEASE_ID_PREFIX = "L-"


class LeaseQuerySet(models.QuerySet):
    def live(self):
        """Holding or waiting for the resource: queued, granted or entered."""
        return self.filter(state__in=LIVE_LEASE_STATES)

    def in_queue_order(self):
        """Holders first, then the queue in arrival order (lease pk = arrival at the server)."""
        waiting = Case(When(state=LeaseState.QUEUED, then=Value(1)), default=Value(0))
        return self.order_by(waiting, "pk")

    def with_queue_position(self):
        """Annotate queue_position: 1 = next in line; None unless queued."""
        ahead = (
            Lease.objects.filter(
                resource=OuterRef("resource"), state=LeaseState.QUEUED, pk__lt=OuterRef("pk")
            )
            .order_by()
            .values("resource")
            .annotate(count=Count("pk"))
            .values("count")
        )
        position = Coalesce(Subquery(ahead), Value(0)) + 1
        return self.annotate(queue_position=Case(When(state=LeaseState.QUEUED, then=position)))


class Lease(models.Model):
    """One robot's request for one resource, from arrival to its end.

    queued -> granted -> entered -> released, or expired (grant not taken up in time),
    revoked (by an administrator) or dropped (robot offline while queued or granted).
    """

    resource = models.ForeignKey(Resource, on_delete=models.CASCADE, related_name="leases")
    robot = models.ForeignKey(Robot, on_delete=models.CASCADE, related_name="leases")
    request_id = models.CharField(
        max_length=64,
        blank=True,
        help_text="the robot's latest acquire request id for this lease; "
        "blank if it entered without asking",
    )
    state = models.CharField(max_length=16, choices=LeaseState, default=LeaseState.QUEUED)
    from_floor = models.ForeignKey(
        Floor, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    to_floor = models.ForeignKey(
        Floor,
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="+",
        help_text="elevators: the floor the robot rides to",
    )
    requested_at = models.DateTimeField(help_text="arrival of the request at the server")
    granted_at = models.DateTimeField(null=True, blank=True)
    expires_at = models.DateTimeField(
        null=True, blank=True, help_text="a grant not entered by then passes to the next in line"
    )
    entered_at = models.DateTimeField(null=True, blank=True)
    ended_at = models.DateTimeField(null=True, blank=True)
    end_cause = models.CharField(max_length=20, choices=LeaseEndCause, blank=True)
    ended_by = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    hard_limit_alerted_at = models.DateTimeField(
        null=True,
        blank=True,
        help_text="when operators were last alerted that the robot is silent inside",
    )

    objects = LeaseQuerySet.as_manager()

    class Meta:
        ordering = ["id"]
        constraints = [
            models.UniqueConstraint(
                fields=["robot", "request_id"],
                condition=~Q(request_id=""),
                name="lease_request_once",
            ),
            models.UniqueConstraint(
                fields=["robot", "resource"],
                condition=Q(state__in=LIVE_LEASE_STATES),
                name="lease_one_live_per_robot_and_resource",
            ),
        ]
        indexes = [
            models.Index(
                fields=["resource", "id"],
                condition=Q(state__in=LIVE_LEASE_STATES),
                name="lease_live",
            ),
            models.Index(
                fields=["expires_at"], condition=Q(state=LeaseState.GRANTED), name="lease_grant_due"
            ),
            # The reports' waits per resource within a period.
            models.Index(fields=["resource", "requested_at"], name="lease_resource_requested"),
            # A grant's time, never before the end it follows (resources.leases._grant).
            models.Index(fields=["resource", "ended_at"], name="lease_resource_ended"),
        ]

    def __str__(self):
        return f"{self.public_id} ({self.state})"

    @property
    def public_id(self) -> str:
        return f"{LEASE_ID_PREFIX}{self.pk}"

    @staticmethod
    def pk_from_public_id(public_id: str) -> int | None:
        return code_pk(public_id, LEASE_ID_PREFIX)

    @property
    def board_key(self) -> str:
        """Key of this lease's board messages: a grant supersedes an unacked queued message."""
        return f"lease:{self.pk}"

    @property
    def holds(self) -> bool:
        """Counts against the resource's capacity."""
        return self.state in HOLDING_LEASE_STATES

    @property
    def entered_without_grant(self) -> bool:
        return self.entered_at is not None and self.granted_at is None

    def grant(self, *, now: datetime, timeout: float) -> None:
        self.state = LeaseState.GRANTED
        self.granted_at = now
        self.expires_at = now + timedelta(seconds=timeout)

    def grant_take_back(self) -> None:
        """Back in the queue, in its old place (lease pk order): a grant not used yet."""
        self.state = LeaseState.QUEUED
        self.granted_at = self.expires_at = None

    def enter(self, *, now: datetime) -> None:
        self.state = LeaseState.ENTERED
        self.entered_at = now

    def end(self, *, state: str, cause: str, now: datetime, by=None) -> None:
        self.state = state
        self.end_cause = cause
        self.ended_at = now
        self.ended_by = by

    def silent_since(self) -> datetime:
        """When the robot was last heard from (or entered, if later)."""
        seen = self.robot.last_seen_at
        return max(seen, self.entered_at) if seen and self.entered_at else seen or self.entered_at

    def past_hard_limit(self, now: datetime, hard_limit: float) -> bool:
        """Inside the resource and silent for at least `hard_limit` seconds."""
        if self.state != LeaseState.ENTERED:
            return False
        return self.silent_since() + timedelta(seconds=hard_limit) <= now

    def hard_limit_alert_due(self, now: datetime, hard_limit: float) -> bool:
        """Past the hard limit, and operators not yet alerted about this silence."""
        alerted = self.hard_limit_alerted_at
        fresh = alerted is None or alerted < self.silent_since()
        return fresh and self.past_hard_limit(now, hard_limit)
