"""The deliveries page: the request form (the paper's Figure 4a) and the schedule table (4b)."""

import re
from datetime import timedelta

import pytest
from django.utils import timezone

from robots.mapcache import site_map_forget
from robots.models import Floor, Site
from scheduling.models import RecurringRequest, Task
from scheduling.selectors import station_options
from tests import factories
from tests.scheduling.conftest import request

LABELS = [
    ("id_requested_time", "Collection time"),
    ("id_sender", "Sender"),
    ("id_receiver", "Receiver"),
    ("id_contents", "Contents"),
    ("id_pickup", "Pick-up"),
    ("id_dropoff", "Drop-off"),
    ("id_priority", "Priority"),
    ("id_repeat", "Repeat"),
]


def order(client, **fields):
    data = {
        "sender": "Nurse Kim",
        "receiver": "Laboratory reception",
        "contents": "Blood samples",
        "pickup": ["Ward 3"],
        "dropoff": ["Laboratory"],
        "priority": "routine",
        "repeat": "",
    }
    data.update(fields)
    return client.post("/", data)


def error_of(response, field_id: str) -> str:
    """The error shown next to a field (the element its aria-describedby names)."""
    html = response.content.decode()
    found = re.search(rf'<p class="field-error" id="{field_id}_error">([^<]*)</p>', html)
    assert found, f"no error next to {field_id}"
    field = re.search(rf'<(input|select)[^>]*id="{field_id}"[^>]*>', html).group(0)
    assert re.search(rf'aria-describedby="[^"]*{field_id}_error', field), field
    assert 'aria-invalid="true"' in field
    return found.group(1)


def local(moment) -> str:
    return timezone.localtime(moment).strftime("%Y-%m-%dT%H:%M")


def test_it_labels_every_field_as_the_paper_does(nurse_client, site):
    html = nurse_client.get("/").content.decode()

    for field_id, label in LABELS:
        assert f'<label for="{field_id}">{label}</label>' in html
        assert f'id="{field_id}"' in html
    assert '<button type="submit" class="button-primary">Request delivery</button>' in html
    # stations by their names, for the search (static/js/combobox.js)
    assert '"code": "2F-LAB", "name": "Laboratory", "ward": "2F"' in html
    assert 'data-combobox="station-options"' in html


def test_it_requests_a_delivery_like_the_api_does(nurse_client, nurse, site):
    response = order(nurse_client, priority="urgent")

    assert response.status_code == 302
    task = Task.objects.get()
    assert (task.sender, task.receiver, task.contents) == (
        "Nurse Kim",
        "Laboratory reception",
        "Blood samples",
    )
    assert task.requester == nurse
    assert task.priority == "urgent"
    assert task.status == "due"
    assert [(s.action, s.waypoint.code) for s in task.stops.order_by("index")] == [
        ("pickup", "3F-WARD"),
        ("dropoff", "2F-LAB"),
    ]
    assert task.history.get().cause == "request"


def test_it_shows_the_new_delivery_in_the_schedule(nurse_client, site):
    response = order(nurse_client, contents="Insulin")

    page = nurse_client.get(response["Location"]).content.decode()

    code = Task.objects.get().code
    assert f"Delivery {code} requested: Insulin." in page
    row = re.search(rf'<tr data-task="{code}".*?</tr>', page, re.S).group(0)
    assert "Ward 3 → Laboratory" in row
    assert "Due, waiting for a robot" in row


def test_it_takes_station_names_in_any_case_and_codes(nurse_client, site):
    order(nurse_client, pickup=["ward 3"], dropoff=["1f-pharm"])

    assert [s.waypoint.code for s in Task.objects.get().stops.order_by("index")] == [
        "3F-WARD",
        "1F-PHARM",
    ]


def test_it_takes_several_drop_offs_from_several_inputs(nurse_client, site):
    order(nurse_client, pickup=["Pharmacy"], dropoff=["Laboratory", "Ward 3"])

    stops = Task.objects.get().stops.order_by("index")
    assert [(s.action, s.waypoint.code, s.load_change) for s in stops] == [
        ("pickup", "1F-PHARM", 2),
        ("dropoff", "2F-LAB", -1),
        ("dropoff", "3F-WARD", -1),
    ]


def test_it_shows_errors_next_to_their_fields_and_creates_nothing(nurse_client, site):
    response = order(nurse_client, sender="", contents="")

    assert response.status_code == 400
    assert error_of(response, "id_sender") == "Say who sends it: a person or a unit."
    assert error_of(response, "id_contents") == "Say what it carries, e.g. Blood sample."
    assert not Task.objects.exists()


def test_it_shows_every_error_at_once_naming_stations_by_name(nurse_client, site):
    response = order(
        nurse_client,
        sender="",
        requested_time="not a time",
        pickup=["Pharmacy"],
        dropoff=["Laboratory", "laboratory", "Pharmacy"],
    )

    assert response.status_code == 400
    assert error_of(response, "id_sender") == "Say who sends it: a person or a unit."
    assert error_of(response, "id_requested_time") == "Enter a valid date/time."
    assert error_of(response, "id_dropoff_2") == "Laboratory is given twice"
    assert error_of(response, "id_dropoff_3") == "Pharmacy is also a pick-up"
    assert "2F-LAB" not in response.content.decode().split('id="id_dropoff_2_error"')[1][:200]
    assert not Task.objects.exists()


def test_it_shows_an_unknown_station_next_to_its_input(nurse_client, site):
    response = order(nurse_client, dropoff=["Nowhere"])

    assert response.status_code == 400
    assert error_of(response, "id_dropoff") == "unknown station &#x27;Nowhere&#x27;"
    assert 'value="Nowhere"' in response.content.decode()  # what was typed stays
    assert not Task.objects.exists()


def test_it_shows_the_error_of_the_second_stop_next_to_it(nurse_client, site):
    response = order(nurse_client, pickup=["Pharmacy"], dropoff=["Laboratory", "Laboratory"])

    assert "given twice" in error_of(response, "id_dropoff_2")
    assert not Task.objects.exists()


def test_it_refuses_many_to_many_deliveries(nurse_client, site):
    response = order(nurse_client, pickup=["Pharmacy", "Ward 3"], dropoff=["Laboratory", "Dock 1"])

    assert response.status_code == 400
    assert not Task.objects.exists()


def test_it_takes_the_requested_time_left_as_shown_as_now(nurse_client, site):
    shown = local(timezone.now() - timedelta(minutes=5))  # the form stayed open 5 minutes

    response = order(nurse_client, requested_time=shown, **{"initial-requested_time": shown})

    assert response.status_code == 302
    task = Task.objects.get()
    assert abs(task.requested_time - timezone.now()) < timedelta(seconds=30)


def test_it_schedules_a_delivery_for_the_requested_time(nurse_client, site):
    later = timezone.now() + timedelta(hours=2)

    order(nurse_client, requested_time=local(later), **{"initial-requested_time": "x"})

    task = Task.objects.get()
    assert task.status == "scheduled"
    assert local(task.requested_time) == local(later)


def test_it_refuses_a_requested_time_in_the_past_next_to_it(nurse_client, site):
    past = local(timezone.now() - timedelta(hours=1))

    response = order(nurse_client, requested_time=past, **{"initial-requested_time": "x"})

    assert error_of(response, "id_requested_time") == (
        "That time has passed: choose a later one, or leave the time as shown for now."
    )
    assert not Task.objects.exists()


def test_it_creates_a_periodic_request_from_repeat(nurse_client, site):
    order(nurse_client, repeat="times", repeat_times="08:00, 14:00")

    assert RecurringRequest.objects.get().repeat == {"times": ["08:00", "14:00"]}


def test_it_creates_a_request_every_few_minutes_within_a_window(nurse_client, site):
    order(
        nurse_client, repeat="every", repeat_every="30", repeat_from="08:00", repeat_until="18:00"
    )

    repeat = RecurringRequest.objects.get().repeat
    assert repeat == {"every_minutes": 30, "from": "08:00", "until": "18:00"}


@pytest.mark.parametrize(
    ("fields", "field_id", "error"),
    [
        ({"repeat": "times", "repeat_times": "8 o'clock"}, "id_repeat_times", "is not HH:MM"),
        (
            {"repeat": "every", "repeat_every": "30", "repeat_from": "18:00"},
            "id_repeat_until",
            "required with every_minutes",
        ),
        (
            {
                "repeat": "every",
                "repeat_every": "30",
                "repeat_from": "18:00",
                "repeat_until": "08:00",
            },
            "id_repeat_until",
            "must be after from",
        ),
        (
            {"repeat": "every", "repeat_from": "08:00", "repeat_until": "18:00"},
            "id_repeat_every",
            "",
        ),
    ],
)
def test_it_shows_repeat_errors_next_to_their_fields(nurse_client, site, fields, field_id, error):
    response = order(nurse_client, **fields)

    assert error in error_of(response, field_id)
    assert not RecurringRequest.objects.exists()
    assert not Task.objects.exists()


def test_it_asks_for_the_site_when_there_are_several(nurse_client, site):
    other = factories.site_create(site="annex", name="Annex")

    html = nurse_client.get("/").content.decode()
    order(nurse_client, site=other.code)

    assert '<label for="id_site">Site</label>' in html
    assert Task.objects.get().site == other


def test_it_does_not_show_a_site_choice_with_one_site(nurse_client, site):
    html = nurse_client.get("/").content.decode()

    assert Site.objects.count() == 1
    assert '<label for="id_site">' not in html


def test_it_lists_active_and_recently_finished_deliveries(nurse_client, site):
    active, recent, old = request(site), request(site), request(site)
    now = timezone.now()
    Task.objects.filter(pk=recent.pk).update(status="completed", completed_at=now)
    Task.objects.filter(pk=old.pk).update(status="completed", completed_at=now - timedelta(hours=2))

    html = nurse_client.get("/").content.decode()

    assert f'data-task="{active.code}"' in html
    assert f'data-task="{recent.code}"' in html
    assert f'data-task="{old.code}"' not in html


def test_it_renders_the_deliveries_page_in_constant_queries(
    nurse_client, site, django_assert_num_queries
):
    robot = factories.robot_create(site, "R1")
    request(site)
    nurse_client.get("/")  # the site map is cached from now on

    # session, user, the user's groups, sites, the user's sites, tasks, their stops, their
    # give-backs (what disrupted them), open alerts
    with django_assert_num_queries(9):
        nurse_client.get("/")

    for _ in range(10):
        task = request(site, pickups=["1F-PHARM"], dropoffs=["2F-LAB", "3F-WARD"])
        Task.objects.filter(pk=task.pk).update(robot=robot, status="assigned")
    with django_assert_num_queries(9):
        assert nurse_client.get("/").content.count(b"<tr data-task=") == 11


def test_it_takes_a_station_by_a_unique_part_of_its_name(nurse_client, site):
    order(nurse_client, pickup=["pharm"], dropoff=["ward 3"])

    stops = Task.objects.get().stops.order_by("index")
    assert [s.waypoint.code for s in stops] == ["1F-PHARM", "3F-WARD"]


def test_it_names_the_stations_a_part_of_a_name_matches(nurse_client, site):
    response = order(nurse_client, pickup=["Laboratory"], dropoff=["ar"])

    assert response.status_code == 400
    assert error_of(response, "id_dropoff") == (
        "“ar” matches 2 stations (Pharmacy, Ward 3): type more of the name."
    )
    assert not Task.objects.exists()


def test_it_offers_each_station_with_its_ward_for_the_search(site):
    Floor.objects.filter(site=site, code="3F").update(name="Ward 3 and day surgery")
    site_map_forget(site.pk)

    options = station_options(site=site)

    assert {"code": "3F-WARD", "name": "Ward 3", "ward": "Ward 3 and day surgery"} in options
    assert {"code": "2F-LAB", "name": "Laboratory", "ward": "2F"} in options  # no floor name
