import os

from celery import Celery
from celery.signals import setup_logging

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")

app = Celery("hospital_delivery")
app.config_from_object("django.conf:settings", namespace="CELERY")
app.autodiscover_tasks()


@setup_logging.connect
def keep_django_logging(**kwargs) -> None:
    """Celery's worker and beat log through settings.LOGGING (configured by django.setup), as
    every other process does: the same levels (LOG_LEVEL), format and time zone."""
