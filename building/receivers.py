"""The building's receivers of lower layers' hooks (hospital_delivery/extensions.py)."""

from building.services import device_follow_lease


def on_lease_changed(*, lease, resource) -> None:
    device_follow_lease(lease=lease, resource=resource)
