from celery import shared_task

from resources import leases


@shared_task
def lease_sweep():
    leases.lease_sweep()
