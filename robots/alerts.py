"""Operator alerts: raised by services when a person must act, acknowledged by an operator."""

from django.db import IntegrityError, transaction
from django.utils import timezone

from boards.events import publish_on_commit
from robots.models import Alert


def alert_raise(
    *,
    site_id: int,
    kind: str,
    key: str,
    message: str,
    robot=None,
    resource=None,
    task: str = "",
) -> Alert:
    """Raise an alert unless one with the same key is still open; returns the open one."""
    existing = Alert.objects.open().filter(key=key).first()
    if existing is not None:
        return existing
    try:
        with transaction.atomic():
            alert = Alert.objects.create(
                site_id=site_id,
                kind=kind,
                key=key,
                message=message,
                robot=robot,
                resource=resource,
                task=task,
            )
    except IntegrityError:  # raised concurrently by another process
        return Alert.objects.open().get(key=key)
    publish_on_commit(site_id=site_id, kind="alert", data=alert_wire(alert))
    return alert


def alert_acknowledge(*, alert: Alert, user) -> bool:
    """Acknowledge an open alert; False if someone already had."""
    acknowledged = (
        Alert.objects.open()
        .filter(pk=alert.pk)
        .update(acknowledged_at=timezone.now(), acknowledged_by=user)
    )
    if acknowledged:
        publish_on_commit(site_id=alert.site_id, kind="alert_acknowledged", data={"id": alert.pk})
    return bool(acknowledged)


def alert_wire(alert: Alert) -> dict:
    return {
        "id": alert.pk,
        "kind": alert.kind,
        "message": alert.message,
        "robot": alert.robot.code if alert.robot else None,
        "task": alert.task or None,
        "raised_at": alert.raised_at.isoformat(),
    }
