"""Pages' sessions end after SESSION_IDLE_MINUTES without a request of the person using them;
the live pages' own re-reads of the state do not keep them alive."""

from datetime import timedelta

import pytest
import time_machine
from django.conf import settings
from django.test import Client
from django.utils import timezone

from tests import factories

pytestmark = pytest.mark.django_db

IDLE = timedelta(minutes=settings.SESSION_IDLE_MINUTES)
MINUTE = timedelta(minutes=1)


def signed_in(at) -> Client:
    client = Client()
    with time_machine.travel(at, tick=False):
        client.force_login(factories.user_create("kim", "nurse"))
    return client


def still_signed_in(client: Client, at) -> bool:
    with time_machine.travel(at, tick=False):
        response = client.get("/")
    assert response.status_code in (200, 302)
    return response.status_code == 200


def test_the_default_idle_time_is_half_an_hour():
    assert settings.SESSION_IDLE_MINUTES == 30
    assert settings.SESSION_COOKIE_AGE == 30 * 60


def test_a_session_unused_past_the_idle_time_ends(site):
    start = timezone.now()
    client = signed_in(start)

    assert still_signed_in(client, start + IDLE - MINUTE)  # and this request renews it
    assert still_signed_in(client, start + 2 * IDLE - 2 * MINUTE)
    assert not still_signed_in(client, start + 3 * IDLE)


def test_the_live_pages_re_reads_do_not_keep_it_alive(site):
    start = timezone.now()
    client = signed_in(start)
    for minutes in range(5, settings.SESSION_IDLE_MINUTES, 5):
        with time_machine.travel(start + timedelta(minutes=minutes), tick=False):
            assert client.get(f"/live/{site.code}/state.json").status_code == 200

    assert not still_signed_in(client, start + IDLE + MINUTE)
