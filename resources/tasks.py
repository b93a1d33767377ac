from celery import shared_task

from core.sweeps import sweep_report
from resources import leases


@shared_task
def lease_sweep():
    sweep_report("lease sweep", leases.lease_sweep())
