from django.db import models
from django.db.models import Q
from django.utils import timezone

from boards.choices import EventType, MessageType, RequestType
from core.codes import code_pk

MESSAGE_ID_PREFIX = "m-"


class BoardMessageQuerySet(models.QuerySet):
    def pending(self):
        """On the board: neither acked by the robot nor withdrawn by the server."""
        return self.filter(acked_at__isnull=True, withdrawn_at__isnull=True)

    def with_public_ids(self, public_ids):
        pks = [pk for pk in map(BoardMessage.pk_from_public_id, public_ids) if pk is not None]
        return self.filter(pk__in=pks)


class BoardMessage(models.Model):
    """Something posted for one robot; it travels in every heartbeat response until acked."""

    robot = models.ForeignKey(
        "robots.Robot", on_delete=models.CASCADE, related_name="board_messages"
    )
    type = models.CharField(max_length=32, choices=MessageType)
    body = models.JSONField(default=dict, help_text="fields sent besides id and type")
    key = models.CharField(
        max_length=100,
        blank=True,
        help_text="messages with the same key replace each other when posted with supersede",
    )
    posted_at = models.DateTimeField(default=timezone.now)
    acked_at = models.DateTimeField(null=True, blank=True)
    withdrawn_at = models.DateTimeField(null=True, blank=True)
    withdraw_reason = models.CharField(max_length=200, blank=True)

    objects = BoardMessageQuerySet.as_manager()

    class Meta:
        ordering = ["id"]
        indexes = [
            models.Index(
                fields=["robot", "id"],
                condition=Q(acked_at__isnull=True, withdrawn_at__isnull=True),
                name="board_message_pending",
            ),
            models.Index(fields=["robot", "key"], name="board_message_key"),
        ]

    def __str__(self):
        return f"{self.public_id} {self.type} for {self.robot_id}"

    @property
    def public_id(self) -> str:
        return f"{MESSAGE_ID_PREFIX}{self.pk}"

    @staticmethod
    def pk_from_public_id(public_id: str) -> int | None:
        return code_pk(public_id, MESSAGE_ID_PREFIX)

    @property
    def is_pending(self) -> bool:
        return self.acked_at is None and self.withdrawn_at is None


class RobotEvent(models.Model):
    """An event a robot reported, applied once: the history behind tasks and leases."""

    robot = models.ForeignKey("robots.Robot", on_delete=models.CASCADE, related_name="events")
    event_id = models.CharField(max_length=64)
    type = models.CharField(max_length=32, choices=EventType)
    at = models.DateTimeField(null=True, blank=True, help_text="by the robot's clock")
    task = models.CharField(max_length=32, blank=True, db_index=True)
    stop = models.PositiveSmallIntegerField(null=True, blank=True)
    resource = models.CharField(max_length=64, blank=True)
    data = models.JSONField(default=dict, help_text="the event as the robot sent it")
    received_at = models.DateTimeField(default=timezone.now)
    boot_id = models.CharField(max_length=64)
    seq = models.BigIntegerField()

    class Meta:
        ordering = ["id"]
        constraints = [
            models.UniqueConstraint(fields=["robot", "event_id"], name="robot_event_once"),
        ]

    def __str__(self):
        return f"{self.robot_id} {self.event_id} {self.type}"


class RobotRequest(models.Model):
    """An acquire/release request of a robot, stored once by its id for the resource controller."""

    robot = models.ForeignKey("robots.Robot", on_delete=models.CASCADE, related_name="requests")
    request_id = models.CharField(max_length=64)
    type = models.CharField(max_length=16, choices=RequestType)
    resource = models.CharField(max_length=64)
    to_floor = models.CharField(max_length=32, blank=True)
    data = models.JSONField(default=dict, help_text="the request as the robot sent it")
    received_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["id"]
        constraints = [
            models.UniqueConstraint(fields=["robot", "request_id"], name="robot_request_once"),
        ]

    def __str__(self):
        return f"{self.robot_id} {self.request_id} {self.type} {self.resource}"
