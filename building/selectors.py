"""Reads of the building's devices, for the operator's lift and door panels."""

from dataclasses import dataclass

from building.models import Device
from robots.models import Floor, Site


@dataclass(frozen=True)
class DevicePanel:
    device: Device
    car_floor: str | None  # lifts: where the car is
    requested_floor: str | None  # lifts: where it was sent
    floors: list[tuple[str, str]]  # lifts: (code, label) of the floors it serves, for "send"


def device_panels(*, site: Site) -> dict[str, DevicePanel]:
    """Each driven resource's device by resource code (two queries)."""
    devices = Device.objects.filter(resource__site=site).select_related(
        "resource", "current_floor", "requested_floor"
    )
    served = _floors_served(site)
    return {
        device.resource.code: DevicePanel(
            device=device,
            car_floor=device.current_floor.code if device.current_floor else None,
            requested_floor=device.requested_floor.code if device.requested_floor else None,
            floors=served.get(device.resource_id, []),
        )
        for device in devices
    }


def _floors_served(site: Site) -> dict[int, list[tuple[str, str]]]:
    rows = (
        Floor.objects.filter(site=site, waypoints__waiting_for__kind="elevator")
        .values_list("waypoints__waiting_for", "code", "name", "level")
        .order_by("level")
        .distinct()
    )
    served: dict[int, list[tuple[str, str]]] = {}
    for resource_id, code, name, _level in rows:
        served.setdefault(resource_id, []).append((code, name or code))
    return served
