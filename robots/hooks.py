"""The fleet's extension point (receivers: hospital_delivery/extensions.py, in order)."""

from core.hooks import Hook

# Called inside the transaction that records a presence flip (by a heartbeat or the sweep),
# robot row locked. old and new are robots.choices.Presence values; at is a datetime.
presence_changed = Hook("presence_changed", "robot: Robot, old: str, new: str, at: datetime")

# Called inside the transaction that gives a robot a new token (its old one stops working):
# a socket is authenticated once, when it opens, so those of the old token must close.
token_issued = Hook("token_issued", "robot: Robot (token_issued_at set)")
