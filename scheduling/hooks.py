"""The scheduler's extension points (receivers: hospital_delivery/extensions.py)."""

from core.hooks import Hook

# Called inside the transaction that starts (active) or ends a site's fire alarm, after its
# robots were told and its lift grants taken back: the building stops the cars with a robot
# inside at their next floor and lets the robots out, and at the all-clear takes on to their
# destinations the robots still inside. `reason`: words for the robots' operators.
fire_alarm_changed = Hook(
    "fire_alarm_changed", "site: Site, active: bool, reason: str, now: datetime"
)
