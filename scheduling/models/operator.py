"""Operators' commands to robots (scheduling/services/operator.py), kept so the robot page shows
them."""

from django.conf import settings
from django.db import models
from django.utils import timezone

from scheduling.choices import OPERATOR_ACTION_CHOICES


class OperatorAction(models.Model):
    """One Pause, Resume or Return to dock of a robot (who, when, and the board message that
    carried it), or a resource taken out of or returned to service (`resource`, with `note`)."""

    robot = models.ForeignKey(
        "robots.Robot",
        null=True,
        blank=True,
        on_delete=models.CASCADE,
        related_name="operator_actions",
    )
    resource = models.ForeignKey(
        "robots.Resource",
        null=True,
        blank=True,
        on_delete=models.CASCADE,
        related_name="operator_actions",
    )
    action = models.CharField(max_length=16, choices=OPERATOR_ACTION_CHOICES)
    note = models.CharField(max_length=200, blank=True, help_text="the operator's reason")
    by = models.ForeignKey(
        settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    at = models.DateTimeField(default=timezone.now)
    message = models.ForeignKey(
        "boards.BoardMessage",
        null=True,
        blank=True,
        on_delete=models.SET_NULL,
        related_name="+",
        help_text="the action message posted on the robot's board",
    )

    class Meta:
        ordering = ["-at", "-id"]
        indexes = [models.Index(fields=["robot", "-at"], name="operator_action_recent")]

    def __str__(self):
        subject = self.robot_id or f"resource {self.resource_id}"
        return f"{self.get_action_display()} {subject} at {self.at:%Y-%m-%d %H:%M:%S}"
