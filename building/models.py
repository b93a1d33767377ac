"""A lift or door of the building as the server drives it: what it asks and what it hears.

One row per elevator or door resource, created the first time a lease of it needs driving.
The request half is written by the services (building/services.py) in the lease's
transaction; an adapter sends it (building/adapters/). The report half is written only by
device_report, from whatever the device (or the simulation) says.
"""

from django.db import models

from building.choices import AdapterKind, DoorState, Motion


class Device(models.Model):
    resource = models.OneToOneField(
        "robots.Resource", on_delete=models.CASCADE, related_name="device"
    )
    adapter = models.CharField(max_length=8, choices=AdapterKind, default=AdapterKind.SIM)

    # What the server asks (Open-RMF's LiftRequest / DoorRequest).
    session = models.CharField(
        max_length=64, blank=True, help_text="the lease served (L-12); blank: nobody"
    )
    requested_floor = models.ForeignKey(
        "robots.Floor", null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    requested_door = models.CharField(max_length=8, choices=DoorState, default=DoorState.CLOSED)
    held_by_operator = models.BooleanField(
        default=False, help_text="an operator holds the doors open, whoever the lease"
    )
    request_seq = models.PositiveIntegerField(default=0, help_text="bumped by every new request")
    sent_seq = models.PositiveIntegerField(default=0, help_text="the last request sent (MQTT)")

    # What the device says (Open-RMF's LiftState / DoorState).
    current_floor = models.ForeignKey(
        "robots.Floor", null=True, blank=True, on_delete=models.SET_NULL, related_name="+"
    )
    motion = models.CharField(max_length=8, choices=Motion, default=Motion.STOPPED)
    door = models.CharField(max_length=8, choices=DoorState, default=DoorState.CLOSED)
    fault = models.CharField(max_length=200, blank=True)
    reported_at = models.DateTimeField(help_text="its last report; silent too long: a fault")
    state_since = models.DateTimeField(
        help_text="simulation: when the car or doors began their current motion"
    )
    announced = models.CharField(
        max_length=100, blank=True, help_text="the last stop told to the lease's robot"
    )

    class Meta:
        ordering = ["resource_id"]

    def __str__(self):
        return f"{self.resource} ({self.get_adapter_display()})"

    @property
    def wants_door_open(self) -> bool:
        return self.held_by_operator or self.requested_door == DoorState.OPEN
