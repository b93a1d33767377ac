"""Celery tasks: take nothing, call one service."""

from celery import shared_task
from django.utils import timezone

from core.sweeps import sweep_report
from reports import rollups


@shared_task
def rollup_sweep() -> None:
    sweep_report("report roll-ups", {"days stored": rollups.rollup_sweep(now=timezone.now())})
