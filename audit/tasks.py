"""Celery tasks: take nothing, call one service."""

from celery import shared_task
from django.utils import timezone

from audit.services import entries_sweep
from core.sweeps import sweep_report


@shared_task
def retention_sweep() -> None:
    sweep_report("audit retention", {"entries removed": entries_sweep(now=timezone.now())})
