from celery import shared_task

from robots import leases, services


@shared_task
def presence_sweep():
    services.presence_sweep()


@shared_task
def lease_sweep():
    leases.lease_sweep()
