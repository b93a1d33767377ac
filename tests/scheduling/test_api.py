"""POST/GET /api/v1/tasks/ and cancel: validation, shapes, history, auth and the schema."""

import copy
from datetime import timedelta
from unittest.mock import ANY

import pytest
from django.db import connection
from django.test import Client
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from robots.models import Alert
from robots.sitefile import site_load
from scheduling.models import RecurringRequest, Task, TaskStop, TaskTransition
from tests import factories
from tests.scheduling.conftest import request


@pytest.fixture
def api(staff):
    client = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")

    def call(method, path, body=None):
        url = f"/api/v1/{path}"
        if method == "get":
            return client.get(url)
        return client.post(url, body or {}, content_type="application/json")

    return call


def valid(**overrides) -> dict:
    body = {
        "sender": "Pharmacy",
        "receiver": "Nurse Kim",
        "contents": "Insulin",
        "priority": "urgent",
        "pickups": ["1F-PHARM"],
        "dropoffs": ["3F-WARD"],
    }
    body.update(overrides)
    return body


def test_it_creates_an_on_demand_task(api, site, staff, django_capture_on_commit_callbacks):
    with django_capture_on_commit_callbacks() as callbacks:
        response = api("post", "tasks/", valid())

    assert response.status_code == 201, response.content
    body = response.json()
    task = Task.objects.get()
    assert body["code"] == task.code == f"T-{task.pk:04d}"
    assert body["status"] == "due"
    assert body["requester"] == staff.username
    assert body["priority"] == "urgent"
    assert [(s["stop"], s["action"], s["waypoint"]) for s in body["stops"]] == [
        (0, "pickup", "1F-PHARM"),
        (1, "dropoff", "3F-WARD"),
    ]
    assert [(h["old"], h["new"], h["cause"], h["user"]) for h in body["history"]] == [
        ("", "due", "request", staff.username)
    ]
    # The live pushes: the task, and the operators' alert (an urgent task no robot can take);
    # it stays due for the due sweep (no Celery message). The activity log writes its two lines
    # after commit too.
    pushes = [each.__qualname__ for each in callbacks]
    assert pushes.count("publish_on_commit.<locals>.<lambda>") == 2
    assert len(pushes) == 4
    assert Alert.objects.open().get(task=task.code).kind == "deadline_at_risk"


def test_it_answers_a_task_already_given_to_a_free_robot(api, r1):
    response = api("post", "tasks/", valid())

    assert response.status_code == 201, response.content
    body = response.json()
    assert (body["status"], body["robot"]) == ("assigned", "R1")
    assert [h["cause"] for h in body["history"]] == ["request", "allocation"]


@pytest.mark.parametrize(
    "overrides",
    [
        {},  # given to R1 at once: its plan, ETAs and allocation in the history
        {"priority": "stat", "due_by": "in a minute"},  # late: its lateness note
        {"secure": True},  # R1 has no lockable compartment: stays due, with why
        {"requested_time": "in two hours"},
        {"repeat": {"times": ["08:00"]}},
    ],
)
def test_the_answer_to_a_request_is_the_task_as_it_then_reads(api, r1, overrides):
    # The answer is built from what the request holds, not read back (bench/latency.py).
    soon = {"in a minute": timedelta(minutes=1), "in two hours": timedelta(hours=2)}
    body = {
        name: (timezone.now() + soon[value]).isoformat() if str(value) in soon else value
        for name, value in overrides.items()
    }

    response = api("post", "tasks/", valid(**body))

    assert response.status_code == 201, response.content
    answer = response.json()
    answer.pop("pin", None)  # the answer alone carries a secure delivery's PIN
    assert answer == api("get", f"tasks/{answer['code']}").json()


def test_it_schedules_a_task_requested_for_later(api, site):
    later = timezone.now() + timedelta(hours=2)

    response = api("post", "tasks/", valid(requested_time=later.isoformat()))

    assert response.status_code == 201
    assert response.json()["status"] == "scheduled"


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"pickups": ["1F-NOWHERE"]}, "pickups[0]"),
        ({"dropoffs": ["3F-WARD", "1F-HALL"]}, "dropoffs[1]"),  # not a station
        ({"dropoffs": ["1F-PHARM"]}, "dropoffs[0]"),  # same as the pick-up
        ({"dropoffs": ["3F-WARD", "3F-WARD"]}, "dropoffs[1]"),
        ({"pickups": []}, "pickups"),
        ({"pickups": ["1F-PHARM", "2F-LAB"], "dropoffs": ["3F-WARD", "1F-DOCK-1"]}, "dropoffs[1]"),
        ({"pickups": ["1F-PHARM", "2F-LAB"], "dropoffs": ["3F-WARD", "3F-WARD"]}, "dropoffs[1]"),
        ({"requested_time": "2020-01-01T08:00:00Z"}, "requested_time"),
        ({"requested_time": "tomorrow"}, "requested_time"),
        ({"priority": "asap"}, "priority"),
        ({"sender": 7}, "sender"),
        ({"contents": ""}, "contents"),
        ({"site": "elsewhere"}, "site"),
        ({"repeat": {}}, "repeat"),
        ({"repeat": {"times": ["8am"]}}, "repeat.times[0]"),
        ({"repeat": {"times": ["08:00"], "every_minutes": 5}}, "repeat"),
        (
            {"repeat": {"every_minutes": 0, "from": "08:00", "until": "20:00"}},
            "repeat.every_minutes",
        ),
        ({"repeat": {"every_minutes": 60, "until": "20:00"}}, "repeat.from"),
        ({"repeat": {"every_minutes": 60, "from": "20:00", "until": "08:00"}}, "repeat.until"),
    ],
)
def test_it_refuses_an_invalid_request_naming_the_field(api, site, overrides, field):
    body = valid(**overrides)

    response = api("post", "tasks/", body)

    assert response.status_code == 400, response.content
    assert response.json()["error"] == "invalid"
    assert field in response.json()["detail"], response.json()
    assert not Task.objects.exists()
    assert not RecurringRequest.objects.exists()


def test_it_names_every_problem_at_once_and_stations_by_name(api, site):
    body = valid(
        sender="",
        priority="asap",
        requested_time="tomorrow",
        dropoffs=["1F-PHARM", "2F-LAB", "2F-LAB", "NOWHERE"],
        secure=True,
        repeat={"times": ["08:00"]},
    )

    response = api("post", "tasks/", body)

    assert response.status_code == 400, response.content
    assert response.json() == {
        "error": "invalid",
        "detail": {
            "sender": ["This field may not be blank."],
            "priority": ['"asap" is not a valid choice.'],
            "requested_time": [ANY],
            "dropoffs[0]": ["Pharmacy is also a pick-up"],
            "dropoffs[2]": ["Laboratory is given twice"],
            "dropoffs[3]": ["unknown station 'NOWHERE'"],
            "secure": ["a secure delivery cannot repeat: each has a PIN of its own"],
        },
    }
    assert not Task.objects.exists()


def test_it_refuses_many_to_many(api):
    data = copy.deepcopy(factories.TINY_SITE)
    data["floors"][0]["waypoints"].append(
        {"code": "1F-STORE", "x": 10, "y": -10, "kind": "station"}
    )
    data["floors"][0]["edges"].append(["1F-HALL", "1F-STORE"])
    site_load(data=data)

    response = api(
        "post", "tasks/", valid(pickups=["1F-PHARM", "1F-STORE"], dropoffs=["2F-LAB", "3F-WARD"])
    )

    assert response.status_code == 400
    assert list(response.json()["detail"]) == ["dropoffs"]
    assert not Task.objects.exists()


def test_a_request_finds_its_stations_on_the_cached_map(api, site):
    api("post", "tasks/", valid())  # the map of this version read and cached

    with CaptureQueriesContext(connection) as queries:
        response = api("post", "tasks/", valid())

    assert response.status_code == 201, response.content
    assert [s["station"] for s in response.json()["stops"]] == ["Pharmacy", "Ward 3"]
    read = [q["sql"] for q in queries.captured_queries if 'FROM "robots_waypoint"' in q["sql"]]
    assert not read
    stops = Task.objects.with_code(response.json()["code"]).get().stops.order_by("index")
    assert [stop.waypoint.code for stop in stops] == ["1F-PHARM", "3F-WARD"]


def test_a_station_gone_from_a_new_map_version_is_refused(api, site):
    assert api("post", "tasks/", valid()).status_code == 201  # the old version cached
    data = copy.deepcopy(factories.TINY_SITE)
    for floor in data["floors"]:
        for waypoint in floor["waypoints"]:
            if waypoint["code"] == "3F-WARD":
                waypoint["kind"] = "plain"
    site_load(data=data)

    response = api("post", "tasks/", valid())

    assert response.status_code == 400
    assert response.json()["detail"] == {"dropoffs[0]": ["unknown station '3F-WARD'"]}


def test_it_sets_load_changes_by_delivery_type(api, site):
    one_to_many = api("post", "tasks/", valid(dropoffs=["2F-LAB", "3F-WARD"])).json()
    many_to_one = api("post", "tasks/", valid(pickups=["1F-PHARM", "2F-LAB"])).json()

    def changes(code):
        task = Task.objects.with_code(code).get()
        return [(s.action, s.load_change) for s in task.stops.order_by("index")]

    assert changes(one_to_many["code"]) == [("pickup", 2), ("dropoff", -1), ("dropoff", -1)]
    assert changes(many_to_one["code"]) == [("pickup", 1), ("pickup", 1), ("dropoff", -2)]


def test_it_accepts_a_periodic_request_and_answers_its_first_instance(api, site):
    response = api("post", "tasks/", valid(repeat={"times": ["08:00", "14:00"]}))

    assert response.status_code == 201, response.content
    body = response.json()
    recurring = RecurringRequest.objects.get()
    assert body["recurring"] == {
        "id": recurring.pk,
        "repeat": {"times": ["08:00", "14:00"]},
        "active": True,
    }
    assert body["status"] == "scheduled"
    local = timezone.localtime(Task.objects.get().requested_time)
    assert (local.hour, local.minute) in {(8, 0), (14, 0)}


def test_it_lists_tasks_newest_first_and_filters_by_status(api, site):
    first, second = request(site), request(site, requested_time=timezone.now() + timedelta(hours=1))

    listed = api("get", "tasks/").json()["results"]
    scheduled = api("get", "tasks/?status=scheduled").json()["results"]

    assert [t["code"] for t in listed] == [second.code, first.code]
    assert [t["code"] for t in scheduled] == [second.code]
    assert api("get", "tasks/?status=lost").status_code == 400


def test_it_lists_tasks_in_a_constant_number_of_queries(api, site, django_assert_num_queries):
    for _ in range(5):
        request(site)

    # auth, count, tasks (with site, robot, requester, recurring), their stops
    with django_assert_num_queries(4):
        assert len(api("get", "tasks/").json()["results"]) == 5


def test_it_shows_a_task_with_its_history(api, site, staff):
    task = request(site, user=staff)
    TaskTransition.objects.create(task=task, at=timezone.now(), old="due", new="due", cause="sweep")

    body = api("get", f"tasks/{task.code}").json()

    assert body["code"] == task.code
    assert body["robot"] is None
    assert [h["cause"] for h in body["history"]] == ["request", "sweep"]


def test_it_answers_404_for_an_unknown_task(api, site):
    assert api("get", "tasks/T-9999").status_code == 404
    assert api("get", "tasks/banana").status_code == 404
    assert api("post", "tasks/T-9999/cancel").status_code == 404


def test_it_cancels_a_waiting_task_and_refuses_a_second_cancel(api, site, staff):
    task = request(site)

    first = api("post", f"tasks/{task.code}/cancel")
    second = api("post", f"tasks/{task.code}/cancel")

    assert first.status_code == 200
    assert first.json()["status"] == "cancelled"
    assert first.json()["history"][-1]["user"] == staff.username
    assert second.status_code == 409
    assert second.json()["error"] == "conflict"


def test_it_refuses_anonymous_and_non_staff_users(site):
    nurse = factories.staff_create("nurse", is_staff=False)
    task = request(site)
    anonymous, non_staff = Client(), Client(HTTP_AUTHORIZATION=f"Bearer {nurse.api_token_plain}")

    for client, expected in ((anonymous, 401), (non_staff, 403)):
        assert client.get("/api/v1/tasks/").status_code == expected
        assert client.get(f"/api/v1/tasks/{task.code}").status_code == expected
        created = client.post("/api/v1/tasks/", valid(), content_type="application/json")
        assert created.status_code == expected
        assert client.post(f"/api/v1/tasks/{task.code}/cancel").status_code == expected
    assert Task.objects.count() == 1


def test_a_requester_may_cancel_their_own_task(site):
    nurse = factories.staff_create("nurse", is_staff=False)
    task = request(site, user=nurse)
    client = Client(HTTP_AUTHORIZATION=f"Bearer {nurse.api_token_plain}")

    assert client.post(f"/api/v1/tasks/{task.code}/cancel").status_code == 200


def test_it_accepts_a_staff_session(site, staff):
    client = Client()
    client.force_login(staff)

    assert client.get("/api/v1/tasks/").status_code == 200


def test_the_schema_describes_the_task_endpoints(api, site, staff):
    client = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")
    schema = client.get("/api/schema/?format=json").json()

    paths = schema["paths"]
    assert set(paths["/api/v1/tasks/"]) >= {"get", "post"}
    assert "get" in paths["/api/v1/tasks/{code}"]
    assert "post" in paths["/api/v1/tasks/{code}/cancel"]
    request_schema = schema["components"]["schemas"]["TaskRequestRequest"]
    assert set(request_schema["required"]) == {
        "sender",
        "receiver",
        "contents",
        "pickups",
        "dropoffs",
    }
    assert "repeat" in request_schema["properties"]


@pytest.mark.parametrize("later", [False, True], ids=["left to the worker", "scheduled"])
def test_a_request_not_allocated_in_it_answers_as_the_tasks_page_does(api, site, settings, later):
    """Its stops and history read once each (scheduling.selectors.task_detail_of, a prefetch):
    the same answer as the task's page gives."""
    settings.ALLOCATE_ON_REQUEST = False
    api("post", "tasks/", valid())  # the map of this version read and cached
    when = {"requested_time": (timezone.now() + timedelta(hours=1)).isoformat()} if later else {}
    tables = [model._meta.db_table for model in (TaskStop, TaskTransition)]

    with CaptureQueriesContext(connection) as queries:
        created = api("post", "tasks/", valid(pickups=["1F-PHARM"], dropoffs=["2F-LAB"], **when))

    assert created.status_code == 201, created.content
    read = [q["sql"] for q in queries.captured_queries if q["sql"].lstrip().startswith("SELECT")]
    assert [sum(f'FROM "{table}"' in sql for sql in read) for table in tables] == [1, 1]
    answer = created.json()
    assert answer["status"] == ("scheduled" if later else "due")
    assert answer == api("get", f"tasks/{answer['code']}").json()
