"""Operator alerts: raised by services when a person must act, acknowledged by an operator."""

from django.db import IntegrityError, transaction
from django.utils import timezone

from core import changes
from core.said import Said, in_english, words_of
from robots.models import Alert


def alert_raise(
    *,
    site_id: int,
    kind: str,
    key: str,
    message: str | Said,
    robot=None,
    resource=None,
    task: str = "",
) -> Alert:
    """Raise an alert unless one with the same key is still open; returns the open one.
    A Said message is shown in each reader's language; its English is kept as `message`."""
    existing = Alert.objects.open().filter(key=key).first()
    if existing is not None:
        return existing
    try:
        with transaction.atomic():
            alert = Alert.objects.create(
                site_id=site_id,
                kind=kind,
                key=key,
                message=in_english(message),
                words=words_of(message),
                robot=robot,
                resource=resource,
                task=task,
            )
    except IntegrityError:  # raised concurrently by another process
        return Alert.objects.open().get(key=key)
    changes.changed(kind=changes.ALERT, site_id=site_id, subject=alert)
    return alert


def alert_acknowledge(*, alert: Alert, user) -> bool:
    """Acknowledge an open alert; False if someone already had."""
    acknowledged = (
        Alert.objects.open()
        .filter(pk=alert.pk)
        .update(acknowledged_at=timezone.now(), acknowledged_by=user)
    )
    if acknowledged:
        kind = changes.ALERT_ACKNOWLEDGED
        changes.changed(kind=kind, site_id=alert.site_id, subject=alert)
    return bool(acknowledged)


def alerts_close(*, key: str, by=None, at=None) -> int:
    """Acknowledge the open alert with this key, if any, for `by` (what it was about is
    resolved); returns how many were closed (0 or 1)."""
    alert = Alert.objects.open().filter(key=key).first()
    if alert is None:
        return 0
    closed = (
        Alert.objects.open()
        .filter(pk=alert.pk)
        .update(acknowledged_at=at or timezone.now(), acknowledged_by=by)
    )
    if closed:
        changes.changed(kind=changes.ALERT_ACKNOWLEDGED, site_id=alert.site_id, subject=alert)
    return closed
