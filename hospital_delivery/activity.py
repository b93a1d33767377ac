"""The activity log: one line per delivery's status change and per alert raised, at INFO on the
`activity` logger, once the transaction that made it commits.

Every other logger stays at LOG_LEVEL (WARNING by default), so the run command's terminal shows
what people act on (deliveries, alerts, errors) and not the heartbeats and sweeps behind them.
A line names the delivery by its code, its places and robot by their codes, and nothing the
delivery's requester typed nor any secret (a secure delivery's PIN never reaches a log).
"""

import logging

from django.db import transaction

from core import changes

logger = logging.getLogger("activity")


def on_change(*, kind: str, site_id: int, subject, **detail) -> None:
    """Receiver of core.changes.changed (hospital_delivery/extensions.py)."""
    if not logger.isEnabledFor(logging.INFO):
        return
    if kind == changes.TASK and subject.old != subject.new:
        line = _task_line(subject)
    elif kind == changes.ALERT:
        line = _alert_line(subject)
    else:
        return
    transaction.on_commit(lambda: logger.info("%s", line))


def _task_line(entry) -> str:
    task = entry.task
    robot = f" by {entry.robot.code}" if entry.robot is not None else ""
    return (
        f"delivery {task.code}: {entry.old or 'new'} -> {entry.new}{robot} "
        f"({entry.get_cause_display()})"
    )


def _alert_line(alert) -> str:
    return f"alert {alert.get_kind_display()}: {alert.message}"
