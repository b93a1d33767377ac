"""Celery tasks: take ids (or nothing), call one service. All idempotent and safe to retry;
the sweeps (Celery beat, settings.CELERY_BEAT_SCHEDULE) redo whatever a lost message left."""

from celery import shared_task
from django.db import OperationalError

from scheduling import services


@shared_task(autoretry_for=(OperationalError,), retry_backoff=True, max_retries=5)
def allocate_task(task_id: int) -> None:
    services.task_allocate_with_its_site(task_id=task_id)


@shared_task
def due_sweep() -> None:
    services.due_sweep()


@shared_task
def ack_timeout_sweep() -> None:
    services.ack_timeout_sweep()


@shared_task
def recurring_sweep() -> None:
    services.recurring_sweep()
