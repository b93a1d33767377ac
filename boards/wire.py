"""Board contents as robots see them on the wire (protocol v1)."""

from datetime import UTC, datetime


def wire_time(moment: datetime) -> str:
    """2026-11-22T09:14:03.131Z"""
    return moment.astimezone(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def heartbeat_reply_wire(reply) -> dict:
    return {
        "server_time": wire_time(reply.server_time),
        "heartbeat_interval": reply.heartbeat_interval,
        "messages": [message.as_wire() for message in reply.messages],
    }
