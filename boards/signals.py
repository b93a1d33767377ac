from django.dispatch import Signal

# Sent inside a heartbeat's transaction, with the robot row locked, after its acks, events,
# requests and state were stored and before the response's messages are read; so receivers
# may post board messages that go out in this very response. A receiver may raise
# boards.services.HeartbeatRejected to refuse the whole heartbeat with 400: the transaction
# rolls back and nothing of it is applied. Argument: applied (boards.services.AppliedHeartbeat).
heartbeat_applied = Signal()
