"""Users of the pages: nurses, an operator, and someone in neither group."""

import pytest
from django.test import Client

from tests import factories, servers


@pytest.fixture(scope="session", autouse=True)
def celery_sink_queue():
    with servers.celery_sink("ui") as queue:
        yield queue


@pytest.fixture
def other_nurse(db):
    return factories.user_create("lee", "nurse")


@pytest.fixture
def outsider(db):
    return factories.user_create("visitor")


def logged_in(user) -> Client:
    client = Client()
    client.force_login(user)
    return client


@pytest.fixture
def nurse_client(nurse):
    return logged_in(nurse)


@pytest.fixture
def operator_client(operator):
    return logged_in(operator)
