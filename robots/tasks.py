from celery import shared_task

from core.sweeps import sweep_report
from robots import services


@shared_task
def presence_sweep():
    sweep_report("presence sweep", {"presence flips": services.presence_sweep()})
