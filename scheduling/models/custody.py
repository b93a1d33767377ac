"""The chain of custody of a delivery: every hand-off of its items, for the pharmacy's audit."""

from django.db import models
from django.utils.translation import gettext_lazy as _

from scheduling.models.tasks import Task, task_code


class CustodyKind(models.TextChoices):
    LOADED = "loaded", _("Loaded")
    UNLOADED = "unloaded", _("Handed over")
    LOCKED_OUT = "locked_out", _("Kept locked after wrong PINs")
    MOVED_ON = "moved_on", _("Taken away: nobody unloaded it")


class CustodyEntry(models.Model):
    """One hand-off, as the robot reported it: who opened which compartment, where, when, and
    the wrong PINs tried before."""

    task = models.ForeignKey(Task, on_delete=models.PROTECT, related_name="custody")
    kind = models.CharField(max_length=16, choices=CustodyKind)
    at = models.DateTimeField(help_text="when the server applied the robot's event")
    robot = models.ForeignKey(
        "robots.Robot", null=True, on_delete=models.SET_NULL, related_name="+"
    )
    station = models.CharField(max_length=200, blank=True, help_text="the stop's station")
    compartment = models.CharField(max_length=16, blank=True)
    opened_with = models.CharField(max_length=8, blank=True)
    opened_by = models.CharField(max_length=64, blank=True)
    failed_attempts = models.PositiveIntegerField(default=0)
    event = models.ForeignKey(
        "boards.RobotEvent", null=True, on_delete=models.SET_NULL, related_name="+"
    )

    class Meta:
        ordering = ["at", "id"]
        indexes = [models.Index(fields=["at"], name="custody_at")]

    def __str__(self):
        return f"{task_code(self.task_id)} {self.kind} at {self.at:%Y-%m-%d %H:%M:%S}"
