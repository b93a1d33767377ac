"""WSGI entry point of the benchmark and test stacks (bench/stack.py): the project's application
with two differences, set before it loads.

* The URLconf is bench.urls: every project URL plus the bare endpoint the heartbeat benchmark
  compares against. The production URLconf never has it.
* Celery messages sent from requests (allocations on commit) go to the stack's own queue
  (STACK_CELERY_QUEUE), so that stacks sharing a Redis never take each other's messages.
"""

import os

from django.conf import settings
from django.core.wsgi import get_wsgi_application

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")
settings.ROOT_URLCONF = "bench.urls"

application = get_wsgi_application()

_queue = os.environ.get("STACK_CELERY_QUEUE")
if _queue:
    from hospital_delivery.celery import app as _celery_app

    _celery_app.conf.task_default_queue = _queue
