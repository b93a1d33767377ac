"""The heartbeat's hottest statements in plain SQL: its robot found by its token and locked, the
robot's board, and the message a robot acknowledges taken off it.

Every heartbeat runs the first two, and nearly every ack is of one message (a plan, an
action): written once from the models' fields (core/plainsql.py says why).
On PostgreSQL only (its lock clause, UPDATE … RETURNING); other databases use the ORM's
querysets, which give the same instances (tests/boards/test_heartbeat_sql.py).
"""

from datetime import datetime

from django.db import connection

from boards.models import BoardMessage
from core.plainsql import column, columns, loaded, table
from core.tokens import token_hash
from robots.models import Robot, Site
from robots.services import robot_authenticate


def robot_by_token_locked(token: str) -> Robot | None:
    """The robot whose bearer token this is, with its site, its row locked for the rest of the
    transaction as robots.services.robot_lock locks it; None for an unknown token."""
    if connection.vendor != "postgresql":
        return robot_authenticate(token=token, lock=True)
    with connection.cursor() as cursor:
        cursor.execute(_ROBOT_BY_TOKEN_LOCKED, [token_hash(token)])
        row = cursor.fetchone()
    if row is None:
        return None
    robot = loaded(Robot, row[: len(_ROBOT_FIELDS)])
    robot.site = loaded(Site, row[len(_ROBOT_FIELDS) :])
    return robot


def board_pending_of(robot_id: int) -> list[BoardMessage]:
    """The messages on the robot's board (BoardMessage.objects.pending()), oldest first."""
    if connection.vendor != "postgresql":
        return list(BoardMessage.objects.pending().filter(robot_id=robot_id).order_by("id"))
    with connection.cursor() as cursor:
        cursor.execute(_PENDING, [robot_id])
        return [loaded(BoardMessage, row) for row in cursor.fetchall()]


def board_message_ack(robot_id: int, message_id: int, now: datetime) -> BoardMessage | None:
    """The robot's message `message_id` marked acked at `now` if it is on its board (pending),
    as reading it there and saving its `acked_at` would: one statement; else None."""
    if connection.vendor != "postgresql":
        pending = BoardMessage.objects.pending().filter(robot_id=robot_id, pk=message_id)
        message = pending.first()
        if message is not None:
            message.acked_at = now
            message.save(update_fields=["acked_at"])
        return message
    acked_at = BoardMessage._meta.get_field("acked_at").get_db_prep_save(now, connection)
    with connection.cursor() as cursor:
        cursor.execute(_ACK, [acked_at, message_id, robot_id])
        row = cursor.fetchone()
    return None if row is None else loaded(BoardMessage, row)


_ROBOT_FIELDS = Robot._meta.concrete_fields
# Only the robot's row is locked (OF r), not its site's, and FOR NO KEY UPDATE lets rows that
# refer to the robot be inserted meanwhile: as robot_lock does.
_ROBOT_BY_TOKEN_LOCKED = (
    f"SELECT {columns(Robot, 'r')}, {columns(Site, 's')} "
    f"FROM {table(Robot)} r JOIN {table(Site)} s "
    f"ON {column(Site, 'pk', 's')} = {column(Robot, 'site', 'r')} "
    f"WHERE {column(Robot, 'token_hash', 'r')} = %s "
    "LIMIT 1 FOR NO KEY UPDATE OF r"
)
# The pending messages' condition, as BoardMessage.objects.pending() has it.
_IS_PENDING = (
    f"{column(BoardMessage, 'acked_at', 'm')} IS NULL "
    f"AND {column(BoardMessage, 'withdrawn_at', 'm')} IS NULL"
)
_ACK = (
    f"UPDATE {table(BoardMessage)} m SET {column(BoardMessage, 'acked_at')} = %s "
    f"WHERE {column(BoardMessage, 'pk', 'm')} = %s "
    f"AND {column(BoardMessage, 'robot', 'm')} = %s AND {_IS_PENDING} "
    f"RETURNING {columns(BoardMessage, 'm')}"
)
_PENDING = (
    f"SELECT {columns(BoardMessage, 'm')} FROM {table(BoardMessage)} m "
    f"WHERE {column(BoardMessage, 'robot', 'm')} = %s AND {_IS_PENDING} "
    f"ORDER BY {column(BoardMessage, 'pk', 'm')}"
)
