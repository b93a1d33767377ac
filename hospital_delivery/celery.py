import os

from celery import Celery

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")

app = Celery("hospital_delivery")
app.config_from_object("django.conf:settings", namespace="CELERY")
app.autodiscover_tasks()
# The sweeps' watchdog records each sweep's runs (a task_success receiver) in the worker.
app.conf.imports = ("hospital_delivery.healthz",)
