"""What the scheduler last told each robot, and the per-site allocation lock."""

from django.db import models
from django.utils import timezone


class RobotPlan(models.Model):
    """The last plan posted for a robot. Written only with the robot's row locked."""

    robot = models.OneToOneField(
        "robots.Robot", primary_key=True, on_delete=models.CASCADE, related_name="plan"
    )
    version = models.PositiveIntegerField(help_text="plan_version of the last plan posted")
    body = models.JSONField(help_text="the plan message's body as posted")
    message = models.ForeignKey(
        "boards.BoardMessage", null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    posted_at = models.DateTimeField(default=timezone.now)

    def __str__(self):
        return f"plan {self.version} of {self.robot_id}"

    @property
    def is_dock(self) -> bool:
        stops = self.body.get("stops", [])
        return len(stops) == 1 and stops[0].get("action") == "dock"


class AllocationLock(models.Model):
    """One row per site, locked (SELECT ... FOR UPDATE) by allocation and by nothing else.

    Not the Site row itself: FOR UPDATE on it would also block every insert of a row that
    refers to the site (a task, an alert) until the allocation commits, and a heartbeat that
    holds a robot and raises an alert would then deadlock with an allocation waiting for that
    robot; the site loader locks the Site row too. Lock order: this row, then one robot.
    """

    site = models.OneToOneField(
        "robots.Site", primary_key=True, on_delete=models.CASCADE, related_name="+"
    )

    def __str__(self):
        return f"allocation lock of site {self.site_id}"
