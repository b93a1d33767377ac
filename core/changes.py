"""Changes people can see on the pages: every layer reports here what it changed.

A service that changes a robot's state, a task, a lease or an alert calls `changed(...)` inside
the transaction that made the change. The live layer is this hook's receiver
(ui/live/publish.py, connected in hospital_delivery/extensions.py): it builds the page payload
and sends it to the site's pages once the transaction commits. So lower layers never build page
payloads nor touch websockets, and a change nobody listens to costs nothing.
"""

from core.hooks import Hook

# What changed; each has one payload builder in ui/live/payloads.py.
ROBOT = "robot"  # subject: the Robot (its site loaded), after the change
TASK = "task"  # subject: the TaskTransition just recorded (its task as changed)
LEASE = "lease"  # subject: the Lease; detail: resource=its Resource
ALERT = "alert"  # subject: the Alert just raised
RESOURCE = "resource"  # subject: the Resource (its service, or its building device's state)
ALERT_ACKNOWLEDGED = "alert_acknowledged"  # subject: the Alert
ETAS = "etas"  # subject: the Tasks whose ETAs a robot's progress just changed

changed = Hook("changed", "kind: str, site_id: int, subject, **detail")
