"""A VDA 5050 vehicle in a fire alarm on a floor with a refuge point: its new order ends at the
refuge, where it waits; the all-clear orders its delivery again."""

import pytest
from django.db import transaction

from scheduling.services import emergency_end, emergency_start
from tests import factories
from tests.vda5050.conftest import deliver
from tests.vda5050.test_link import exchange, state

pytestmark = pytest.mark.django_db


@pytest.fixture
def site(db):
    return factories.site_create(**factories.tiny_site_with_refuge())


def test_a_vehicle_is_ordered_to_the_refuge_and_back_to_its_delivery(link, site, staff):
    exchange(link, state())  # at its dock, on 1F
    deliver(site, ["1F-PHARM"], ["2F-LAB"])
    [first] = exchange(link, state())
    assert first.topic == "order"

    with transaction.atomic():
        alarm = emergency_start(site=site, floors=["1F"], reason="", via="api", by=staff)
    assert alarm.refuges == {"V1": "1F-REFUGE"}
    [to_refuge] = exchange(link, state(orderId=first.body["orderId"]))
    assert to_refuge.topic == "order"
    nodes = [node["nodeId"] for node in to_refuge.body["nodes"]]
    assert nodes == ["1F-DOCK-1", "1F-HALL", "1F-REFUGE"]
    assert all(not node["actions"] for node in to_refuge.body["nodes"])  # no pick on the way

    with transaction.atomic():
        emergency_end(site=site, via="api", by=staff)
    refuge = state(orderId=to_refuge.body["orderId"], lastNodeId="1F-REFUGE")
    [onwards] = exchange(link, refuge)
    assert onwards.body["nodes"][0]["nodeId"] == "1F-REFUGE"
    picks = [a["actionType"] for n in onwards.body["nodes"] for a in n["actions"]]
    assert picks[:1] == ["pick"]
