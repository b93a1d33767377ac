from celery import shared_task

from robots import services


@shared_task
def presence_sweep():
    services.presence_sweep()
