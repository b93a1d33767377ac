"""The resource controller's extension points (receivers: hospital_delivery/extensions.py)."""

from core.hooks import Hook

# Called inside the transaction that changes a lease (created, granted, entered, ended), with
# its resource row locked: the building's devices follow their resources' leases from here.
lease_changed = Hook("lease_changed", "lease: Lease, resource: Resource")

# Called inside the transaction that takes a resource out of service or returns it, resource
# row locked, after its leases' robots were told: routes through it are planned again.
availability_changed = Hook("availability_changed", "resource: Resource, now: datetime")
