"""The message board's extension point (receivers: hospital_delivery/extensions.py, in order)."""

from core.hooks import Hook

# Called inside a heartbeat's transaction, with the robot row locked, after its acks, events,
# requests and state were stored and before the response's messages are read; so receivers
# may post board messages that go out in this very response. A receiver may raise
# boards.services.HeartbeatRejected to refuse the whole heartbeat with 400: the transaction
# rolls back and nothing of it is applied.
heartbeat_applied = Hook("heartbeat_applied", "applied: boards.services.AppliedHeartbeat")
