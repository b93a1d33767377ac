"""Operators' commands to robots (scheduling/services/operator.py), kept so the robot page shows
them."""

from django.conf import settings
from django.db import models
from django.utils import timezone

from scheduling.choices import OperatorActionKind


class OperatorAction(models.Model):
    """One Pause, Resume or Return to dock: who, when, and the board message that carried it."""

    robot = models.ForeignKey(
        "robots.Robot", on_delete=models.CASCADE, related_name="operator_actions"
    )
    action = models.CharField(max_length=16, choices=OperatorActionKind)
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
        return f"{self.get_action_display()} {self.robot_id} at {self.at:%Y-%m-%d %H:%M:%S}"
