import pytest

from hospital_delivery.celery import app as celery_app


@pytest.fixture(autouse=True)
def eager_allocation():
    """Tasks requested in-process are allocated at once, in this process (no broker)."""
    celery_app.conf.task_always_eager = True
    yield
    celery_app.conf.task_always_eager = False
