"""The building's extension points (receivers: hospital_delivery/extensions.py)."""

from core.hooks import Hook

# Called inside the transaction that applies a fire panel's state (building.services
# fire_panel_report): the scheduler starts or ends the site's fire alarm.
fire_panel_changed = Hook(
    "fire_panel_changed", "site: Site, alarm: bool, floors: list[str], reason: str"
)
