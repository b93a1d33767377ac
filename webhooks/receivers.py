"""Receivers of lower layers' hooks, connected in hospital_delivery/extensions.py."""

from webhooks import services, tasks


def on_change(*, kind: str, site_id: int, subject, **detail) -> None:
    """core.changes.changed: a task's status change becomes deliveries, in its transaction,
    sent by Celery once it commits."""
    ids = services.deliveries_for_change(kind=kind, site_id=site_id, subject=subject, **detail)
    services.send_after_commit(ids, tasks.enqueue)
