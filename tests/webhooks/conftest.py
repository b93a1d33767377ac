import pytest

from tests import servers
from webhooks import tasks as webhook_tasks
from webhooks.models import Subscription


@pytest.fixture(scope="session", autouse=True)
def celery_sink_queue():
    with servers.celery_sink("webhooks") as queue:
        yield queue


LOOPBACK = ["127.0.0.0/8"]


@pytest.fixture(autouse=True)
def loopback_allowed(settings):
    """The receivers of these tests listen on 127.0.0.1, which webhooks refuse unless allowed
    (tests/webhooks/test_webhook_targets.py shows the refusal)."""
    settings.WEBHOOK_ALLOWED_NETWORKS = LOOPBACK


@pytest.fixture
def sent(monkeypatch):
    """Delivery ids handed to Celery (the message itself is not sent)."""
    ids = []
    monkeypatch.setattr(webhook_tasks.send_delivery, "delay", ids.append)
    return ids


def subscribe(site, url: str, **fields) -> Subscription:
    subscription = Subscription(site=site, name=fields.pop("name", "Laboratory"), url=url, **fields)
    subscription.full_clean()
    subscription.save()
    return subscription
