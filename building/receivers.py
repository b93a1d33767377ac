"""The building's receivers of other components' hooks (hospital_delivery/extensions.py)."""

from building.services import (
    device_follow_lease,
    elevator_riders_carry_on,
    elevator_riders_let_out,
)


def on_lease_changed(*, lease, resource) -> None:
    device_follow_lease(lease=lease, resource=resource)


def on_fire_alarm_changed(*, site, active, reason, now) -> None:
    if active:
        elevator_riders_let_out(site=site, reason=reason, now=now)
    else:
        elevator_riders_carry_on(site=site, now=now)
