"""A VDA 5050 vehicle in a fire alarm: stopped by the instant action startPause, resumed by
stopPause at the all-clear, as an operator's Pause and Resume."""

import pytest
from django.db import transaction

from scheduling.services import emergency_end, emergency_start
from tests.vda5050.test_link import exchange, state

pytestmark = pytest.mark.django_db


def test_a_vehicle_on_an_alarm_floor_pauses_and_resumes_at_the_all_clear(link, site, staff):
    exchange(link, state())  # it reports itself at its dock, on 1F
    with transaction.atomic():
        alarm = emergency_start(site=site, floors=["1F"], reason="", via="api", by=staff)
    assert alarm.stopped_robots == ["V1"]
    [pause] = exchange(link, state())
    assert pause.topic == "instantActions"
    # The bridge asks for the state that confirms it in the same message (stateRequest).
    assert [a["actionType"] for a in pause.body["actions"]] == ["startPause", "stateRequest"]
    assert exchange(link, state(paused=True)) == []

    with transaction.atomic():
        emergency_end(site=site, via="api", by=staff)
    [resume] = exchange(link, state(paused=True))
    assert [a["actionType"] for a in resume.body["actions"]] == ["stopPause", "stateRequest"]
