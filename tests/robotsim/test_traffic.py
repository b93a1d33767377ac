"""The request generator (robotsim.traffic): realistic deliveries through the public task API."""

import random
from pathlib import Path

import pytest
import yaml

from bench.inprocess import InProcessTaskApi
from robots.router import site_map_from_file
from robotsim.traffic import KINDS, Stations, TrafficGenerator, day_requests, request_body
from tests import factories

EULJI = site_map_from_file(yaml.safe_load(Path("sites/eulji.yaml").read_text(encoding="utf-8")))


def test_it_recognises_the_hospitals_stations_by_name():
    stations = Stations.of(EULJI)

    assert (stations.lab_drop, stations.lab_pickup) == ("2F-LAB-DROP", "2F-LAB-PICKUP")
    assert (stations.pharmacy, stations.supply) == ("1F-PHARM", "2F-SUPPLY")
    assert {"6F-WARD-A", "3F-ICU"} <= set(stations.wards)
    assert not {"2F-LAB-DROP", "1F-PHARM", "2F-SUPPLY"} & set(stations.wards)


def test_it_makes_do_on_a_small_site():
    stations = Stations.of(site_map_from_file(factories.TINY_SITE))

    assert (stations.lab_drop, stations.pharmacy, stations.wards) == (
        "2F-LAB",
        "1F-PHARM",
        ("3F-WARD",),
    )
    rng = random.Random(1)
    for kind in KINDS:
        body = request_body(kind, stations, rng)
        assert body["pickups"]
        assert body["dropoffs"]
        assert not set(body["pickups"]) & set(body["dropoffs"])


def test_a_day_has_a_morning_peak_and_medication_rounds_and_is_the_same_for_one_seed():
    stations = Stations.of(EULJI)

    day = day_requests(stations, seed=5)

    assert day == day_requests(stations, seed=5)
    assert day != day_requests(stations, seed=6)
    assert [at for at, _ in day] == sorted(at for at, _ in day)
    assert all(0 <= at < 12 * 3600 for at, _ in day)
    samples = [at for at, body in day if body["contents"] == "Blood samples"]
    morning = sum(at < 2 * 3600 for at in samples)  # 08:00-10:00
    evening = sum(at >= 10 * 3600 for at in samples)  # 18:00-20:00
    assert morning > 2 * evening
    rounds = [(at, body) for at, body in day if body["contents"] == "Medication round"]
    assert [int(at // 3600) for at, _ in rounds] == [1, 1, 5, 5, 9, 9]  # 09:00, 13:00, 17:00
    assert all(len(body["dropoffs"]) >= 2 for _, body in rounds)


@pytest.mark.django_db
def test_every_kind_of_request_is_accepted_by_the_task_api(site, staff):
    api = InProcessTaskApi(staff.api_token_plain)
    generator = TrafficGenerator(
        api, Stations.of(site_map_from_file(factories.TINY_SITE)), rate=60, rng=random.Random(2)
    )

    codes = [generator.post_one() for _ in range(12)]

    assert all(codes)
    assert generator.failed == 0
