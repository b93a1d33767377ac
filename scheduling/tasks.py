"""Celery tasks: take ids (or nothing), call one service. All idempotent and safe to retry;
the sweeps (Celery beat, settings.CELERY_BEAT_SCHEDULE) redo whatever a lost message left."""

from celery import shared_task
from django.db import OperationalError

from core.sweeps import sweep_report
from scheduling import services
from scheduling.pending import allocation_pending_free
from scheduling.services.stuck import stuck_sweep


@shared_task(autoretry_for=(OperationalError,), retry_backoff=True, max_retries=5)
def allocate_task(task_id: int, pending: str = "") -> None:
    if pending:  # the site's claim (scheduling/pending.py); messages sent before it carry none
        allocation_pending_free(pending)
    services.task_allocate_with_its_site(task_id=task_id)


@shared_task
def due_sweep() -> None:
    sweep_report("due sweep", {"tasks assigned": services.due_sweep()})


@shared_task
def ack_timeout_sweep() -> None:
    sweep_report("ack timeouts", {"assignments withdrawn": services.ack_timeout_sweep()})


@shared_task
def recurring_sweep() -> None:
    sweep_report("recurring sweep", {"deliveries created": services.recurring_sweep()})


@shared_task
def unload_timeout_sweep() -> None:
    overdue = services.unload_timeout_sweep()
    sweep_report(
        "unload timeouts",
        {"drop-offs overdue": overdue, "robots moved on": services.unattended_sweep()},
    )


@shared_task(autoretry_for=(OperationalError,), retry_backoff=True, max_retries=5)
def site_reroute(site_id: int, resource: str = "") -> None:
    services.site_reroute(site_id=site_id)


@shared_task
def robot_watch_sweep() -> None:
    returned = services.maintenance_due_sweep()
    sweep_report("robot watch", {"back from maintenance": returned, "stuck": stuck_sweep()})
