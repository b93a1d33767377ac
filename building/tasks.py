from celery import shared_task

from building import services
from core.sweeps import sweep_report


@shared_task
def building_sweep():
    sweep_report("building sweep", services.building_sweep())
