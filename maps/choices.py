from django.db import models
from django.utils.translation import gettext_lazy as _


class Rollout(models.TextChoices):
    """What publishing does when the new map cuts a robot's current route."""

    REFUSE = "refuse", _("Refuse to publish, naming the robots in the way")
    REPLAN = "replan", _("Publish, and re-plan those robots on the new map")
