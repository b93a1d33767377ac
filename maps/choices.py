from django.db import models


class Rollout(models.TextChoices):
    """What publishing does when the new map cuts a robot's current route."""

    REFUSE = "refuse", "Refuse to publish, naming the robots in the way"
    REPLAN = "replan", "Publish, and re-plan those robots on the new map"
