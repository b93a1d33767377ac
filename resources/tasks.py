from celery import shared_task

from core.sweeps import sweep_report
from resources import deadlocks, leases


@shared_task
def lease_sweep():
    # Deadlocks after the expiries: a grant that lapsed may already have broken a cycle.
    counts = leases.lease_sweep()
    sweep_report("lease sweep", counts | {"deadlocks": deadlocks.lease_deadlock_sweep()})
