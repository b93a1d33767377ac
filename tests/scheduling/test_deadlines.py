"""Priorities with due-by times: routine, urgent, STAT (real PostgreSQL, the real allocator)."""

from datetime import timedelta

import pytest
from django.test import Client
from django.utils import timezone

from robots.models import Alert, AlertKind
from scheduling.models import Task
from scheduling.services import task_allocate
from tests.scheduling.conftest import pending_plans, request, route


@pytest.fixture
def post(staff, settings):
    settings.ALLOCATE_ON_REQUEST = True
    client = Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")

    def post(**body):
        body = {
            "sender": "ICU",
            "receiver": "Laboratory",
            "contents": "Blood gas",
            "pickups": ["1F-PHARM"],
            "dropoffs": ["3F-WARD"],
            **body,
        }
        return client.post("/api/v1/tasks/", body, content_type="application/json")

    return post


def test_it_takes_normal_as_the_old_name_of_routine_with_the_sites_due_by(post, site):
    response = post(priority="normal")

    assert response.status_code == 201, response.content
    task = Task.objects.get()
    assert (task.priority, response.json()["priority"]) == ("routine", "routine")
    assert task.due_at == task.requested_time + timedelta(minutes=site.routine_due_minutes)


def test_a_stat_request_is_due_by_the_sites_stat_default_or_by_its_own(post, site):
    default = post(priority="stat").json()
    own_due = timezone.now() + timedelta(minutes=5)
    own = post(priority="stat", due_by=own_due.isoformat()).json()

    stat = Task.objects.with_code(default["code"]).get()
    assert stat.due_at == stat.requested_time + timedelta(minutes=site.stat_due_minutes)
    assert site.stat_due_minutes == 20  # the default, when the site file sets none
    assert Task.objects.with_code(own["code"]).get().due_at == own_due


@pytest.mark.parametrize(
    ("body", "why"),
    [
        ({"due_by": "2020-01-01T08:00:00Z"}, "must be after the requested time"),
        ({"due_by": "soon"}, "ISO-8601"),
        ({"due_by": "2099-01-01T08:00:00Z", "repeat": {"times": ["08:00"]}}, "not with repeat"),
        ({"priority": "asap"}, "not a valid choice"),
    ],
)
def test_it_refuses_a_bad_priority_or_due_by_naming_the_field(post, site, body, why):
    response = post(**body)

    assert response.status_code == 400
    error = response.json()
    field = next(iter(body)) if "repeat" not in body else "due_by"
    assert error["error"] == "invalid"
    assert why in " ".join(error["detail"][field])
    assert not Task.objects.exists()


def test_a_stat_task_goes_ahead_of_a_held_routine_stop_and_gets_the_earlier_eta(r1, site):
    # R1 holds a routine delivery from the pharmacy to the laboratory (2F). A STAT delivery from
    # the pharmacy to ward 3 (3F) comes: by least travel the robot would pass the laboratory
    # first (the lab is on the way up); the STAT drop-off goes ahead of it instead.
    routine = request(site, dropoffs=("2F-LAB",))
    task_allocate(task_id=routine.pk)
    stat = request(site, dropoffs=("3F-WARD",), priority="stat", receiver="Ward 3")

    assert task_allocate(task_id=stat.pk)

    plan = pending_plans(r1)[-1].body
    dropoffs = [code for code, _, action, _ in route(plan) if action == "dropoff"]
    assert dropoffs == [stat.code, routine.code]
    stat.refresh_from_db()
    routine.refresh_from_db()
    assert stat.robot == r1
    assert stat.eta < routine.eta
    # Protocol v1 robots know "normal" and "urgent" only: a STAT task travels as "urgent".
    assert plan["tasks"][stat.code]["priority"] == "urgent"
    assert plan["tasks"][routine.code]["priority"] == "normal"


def test_a_routine_task_with_the_same_stops_keeps_the_least_travel_order(r1, site):
    first = request(site, dropoffs=("2F-LAB",))
    task_allocate(task_id=first.pk)
    second = request(site, dropoffs=("3F-WARD",), receiver="Ward 3")

    assert task_allocate(task_id=second.pk)

    dropoffs = [c for c, _, a, _ in route(pending_plans(r1)[-1].body) if a == "dropoff"]
    assert dropoffs == [first.code, second.code]


def test_an_impossible_deadline_is_reported_in_the_request_answer_and_to_operators(post, r1, site):
    due_by = timezone.now() + timedelta(seconds=30)  # ward 3 is two minutes from the dock

    response = post(priority="stat", due_by=due_by.isoformat())

    assert response.status_code == 201, response.content
    body = response.json()
    assert (body["status"], body["robot"]) == ("assigned", "R1")
    eta = timezone.localtime(Task.objects.with_code(body["code"]).get().eta)
    minutes = max(1, round((eta - due_by).total_seconds() / 60))
    assert body["lateness"] == f"earliest drop-off {eta:%H:%M}, {minutes} min after it is due"
    alert = Alert.objects.open().get(task=body["code"])
    assert alert.kind == AlertKind.DEADLINE_AT_RISK
    assert body["lateness"] in alert.message


def test_a_deadline_that_can_be_met_raises_nothing(post, r1, site):
    body = post(priority="stat").json()

    assert body["robot"] == "R1"
    assert body["lateness"] == ""
    assert not Alert.objects.exists()


def test_a_stat_task_no_robot_can_take_alerts_operators_at_once(post, site):
    body = post(priority="stat").json()

    assert body["status"] == "due"
    alert = Alert.objects.open().get(task=body["code"])
    assert alert.kind == AlertKind.DEADLINE_AT_RISK
    assert "has no robot" in alert.message
