"""Secure deliveries: compartments from the site file, a PIN shown once and checked by the robot
offline from its salted slow hash, custody of every hand-off, lockout, and the audit CSV."""

import copy
import csv
import io
import re

import pytest
from django.test import Client
from django.utils import timezone

from robots.badges import badge_matches
from robots.models import Alert, Robot, SiteMembership, Waypoint
from robots.services import membership_badge_set
from robots.sitefile import SiteFileInvalid, site_load
from robotsim.client import badge_check, pin_check
from scheduling.models import CustodyEntry, Task
from scheduling.pins import pin_matches
from scheduling.services import task_allocate
from scheduling.services.allocation import NO_SECURE_ROUTE
from tests import factories
from tests.scheduling.conftest import Beater, event, plans, request, robot_ready, route, status

LOCKING = [{"code": "A", "lockable": True}, {"code": "B"}]
PICK_DROP = ("pickup", "dropoff")


@pytest.fixture
def locking(site):
    """R2, with a lockable compartment, beside R1, which has none."""
    dock = Waypoint.objects.get(site=site, code="1F-DOCK-2")
    return robot_ready(factories.robot_create(site, "R2", dock=dock, compartments=LOCKING))


@pytest.fixture
def api(staff):
    return Client(HTTP_AUTHORIZATION=f"Bearer {staff.api_token_plain}")


def order(api, **overrides):
    body = {
        "sender": "Pharmacy",
        "receiver": "Ward 3",
        "contents": "Morphine",
        "pickups": ["1F-PHARM"],
        "dropoffs": ["3F-WARD"],
        "secure": True,
        **overrides,
    }
    return api.post("/api/v1/tasks/", body, content_type="application/json")


def test_compartments_in_the_site_file_set_the_capacity(db):
    data = copy.deepcopy(factories.TINY_SITE)
    data["robots"] = [{"code": "RX", "dock": "1F-DOCK-1", "compartments": LOCKING}]
    site_load(data=data)

    robot = Robot.objects.get(code="RX")
    assert (robot.capacity, robot.lockable_compartments) == (2, ["A"])

    data["robots"][0]["capacity"] = 4
    data["robots"][0]["compartments"] = [{"code": "A"}, {"code": "A", "lockable": "yes"}]
    with pytest.raises(SiteFileInvalid) as refused:
        site_load(data=data)
    problems = "\n".join(refused.value.problems)
    assert "robots[0].compartments[1].code: duplicate compartment 'A'" in problems
    assert "robots[0].compartments[1].lockable" in problems
    assert "robots[0].capacity: 4 differs from its 2 compartments" in problems


def test_the_pin_is_answered_once_and_only_its_salted_hash_is_kept(api, site):
    created = order(api)

    assert created.status_code == 201, created.content
    pin = created.json()["pin"]
    assert re.fullmatch(r"\d{8}", pin)  # SECURE_PIN_DIGITS
    task = Task.objects.get()
    assert task.secure
    assert pin not in (task.pin_hash, task.pin_salt)
    assert pin_matches(pin, task.pin)
    assert task.pin.iterations >= 100_000
    assert "pin" not in api.get(f"/api/v1/tasks/{task.code}").json()
    order(api)
    assert Task.objects.latest("pk").pin_salt != task.pin_salt  # a salt of its own


def test_a_secure_delivery_cannot_repeat(api, site):
    refused = order(api, repeat={"times": ["09:00"]})

    assert refused.status_code == 400
    assert refused.json()["detail"] == {
        "secure": ["a secure delivery cannot repeat: each has a PIN of its own"]
    }
    assert not Task.objects.exists()


def test_it_goes_only_to_a_robot_with_a_lockable_compartment(r1, site):
    task = request(site, secure=True)
    assert not task_allocate(task_id=task.pk)
    task.refresh_from_db()
    assert task.waiting_reason == "secure: no available robot has a lockable compartment"

    dock = Waypoint.objects.get(site=site, code="1F-DOCK-2")
    far = robot_ready(factories.robot_create(site, "R2", dock=dock, compartments=LOCKING))
    assert task_allocate(task_id=task.pk)
    task.refresh_from_db()
    assert task.robot == far  # though R1 is as near


def _secure_on_board_at_most(plan: dict) -> int:
    """The most secure deliveries a plan has on board at once (its tasks all secure here)."""
    on_board = most = 0
    for task, _, action, _ in route(plan):
        if not task:
            continue
        on_board += 1 if action == "pickup" else -1
        most = max(most, on_board)
    return most


def test_one_lockable_compartment_takes_one_secure_delivery_at_a_time(site):
    # R2 has two compartments, one lockable, and stands at the pharmacy where both are picked
    # up: counting items, it would load both at once.
    at_pharmacy = factories.robot_create(site, "R2", compartments=LOCKING)
    robot = robot_ready(at_pharmacy, at="1F-PHARM")
    first = request(site, secure=True, dropoffs=("3F-WARD",))
    second = request(site, secure=True, dropoffs=("2F-LAB",))
    assert task_allocate(task_id=first.pk)
    assert task_allocate(task_id=second.pk)

    *_, plan = plans(Beater(robot).beat())

    stops = [(task, action) for task, _, action, _ in route(plan) if task]
    assert sorted(stops) == sorted((t.code, a) for t in (first, second) for a in PICK_DROP)
    assert _secure_on_board_at_most(plan) == 1  # one delivered before the other is loaded


def test_a_second_secure_delivery_goes_to_another_robot_with_its_compartment_free(site):
    carrying = robot_ready(factories.robot_create(site, "R2", compartments=LOCKING), at="1F-PHARM")
    first = request(site, secure=True, dropoffs=("3F-WARD",))
    assert task_allocate(task_id=first.pk)
    Beater(carrying).beat(events=[event("loaded", first.code, 0, compartment="A")])
    other = factories.robot_create(site, "R3", compartments=LOCKING)
    other = robot_ready(other, at="1F-DOCK-1")

    second = request(site, secure=True, dropoffs=("3F-WARD",))
    assert task_allocate(task_id=second.pk)

    second.refresh_from_db()
    assert second.robot == other  # though R2 stands at its pick-up going the same way


def test_a_secure_delivery_waits_for_as_many_lockable_compartments_as_its_items(site):
    robot_ready(factories.robot_create(site, "R2", compartments=LOCKING), at="1F-PHARM")
    two_wards = request(site, secure=True, dropoffs=("3F-WARD", "2F-LAB"))  # two items

    assert not task_allocate(task_id=two_wards.pk)

    two_wards.refresh_from_db()
    assert two_wards.waiting_reason == NO_SECURE_ROUTE
    both = [{"code": "A", "lockable": True}, {"code": "B", "lockable": True}]
    robot_ready(factories.robot_create(site, "R3", compartments=both))
    assert task_allocate(task_id=two_wards.pk)


def test_the_plan_lets_the_robot_check_the_pin_offline(locking, site):
    task = request(site, secure=True)
    assert task_allocate(task_id=task.pk)

    [plan] = plans(Beater(locking).beat())

    secure = plan["tasks"][task.code]["secure"]
    assert secure["max_attempts"] == 3
    assert set(secure["pin"]) == {"algorithm", "iterations", "salt", "hash", "digits"}
    assert pin_check(task.pin_plain, secure)
    wrong = "0" * 8 if task.pin_plain != "0" * 8 else "1" * 8
    assert not pin_check(wrong, secure)
    assert task.pin_plain not in str(plan)


def test_guessing_a_pin_from_a_robots_plan_takes_500_times_the_work_it_did(locking, site):
    # Whoever reads a robot's storage has each plan's salt, iterations and hash: they must try
    # every code of the PIN's length, each at the full iteration count. Six digits at 120,000
    # iterations took a few core-hours (docs/deployment/security.md, "PINs").
    task = request(site, secure=True)
    assert task_allocate(task_id=task.pk)
    [plan] = plans(Beater(locking).beat())
    pin = plan["tasks"][task.code]["secure"]["pin"]

    work = 10 ** pin["digits"] * pin["iterations"]  # PBKDF2 iterations to try every code

    assert pin["digits"] == len(task.pin_plain) >= 8
    assert pin["iterations"] >= 600_000
    assert work >= 500 * 10**6 * 120_000


def test_every_hand_off_is_kept_in_the_custody_record_and_history(locking, site, nurse):
    task = request(site, secure=True, user=nurse, dropoffs=("1F-PHARM",), pickups=("2F-LAB",))
    task_allocate(task_id=task.pk)
    beater = Beater(locking)
    loaded = event("loaded", task.code, 0, compartment="A", opened_with="badge", opened_by="b-17")
    beater.beat(events=[loaded])
    opened = event("unloaded", task.code, 1, compartment="A", opened_with="pin", failed_attempts=2)
    beater.beat(events=[opened])

    assert status(task) == "delivered"
    rows = list(
        CustodyEntry.objects.values_list(
            "kind", "station", "compartment", "opened_with", "opened_by", "failed_attempts"
        )
    )
    assert rows == [
        ("loaded", "Laboratory", "A", "badge", "b-17", 0),
        ("unloaded", "Pharmacy", "A", "pin", "", 2),
    ]
    notes = list(task.history.values_list("note", flat=True))
    assert "Loaded into compartment A at Laboratory (b-17)" in notes
    handed = "Handed over at Pharmacy from compartment A, opened with the delivery's PIN"
    assert f"{handed} after 2 wrong PINs" in notes


def test_wrong_pins_keep_it_locked_and_alert_operators(locking, site):
    task = request(site, secure=True)
    task_allocate(task_id=task.pk)
    beater = Beater(locking)
    beater.beat(events=[event("loaded", task.code, 0, compartment="A")])

    locked = event("compartment_locked", task.code, 1, compartment="A", failed_attempts=3)
    beater.beat(events=[locked])

    assert status(task) == "picked_up"
    entry = CustodyEntry.objects.last()
    assert (entry.kind, entry.compartment, entry.failed_attempts) == ("locked_out", "A", 3)
    [alert] = Alert.objects.all()
    assert (alert.kind, alert.robot, alert.task) == ("compartment_locked", locking, task.code)
    assert "Compartment A kept locked at Laboratory after 3 wrong PINs" in alert.message


def test_compartment_locked_needs_a_compartment(locking, site):
    task = request(site, secure=True)
    task_allocate(task_id=task.pk)

    response = Beater(locking).post(events=[event("compartment_locked", task.code)])

    assert response.status_code == 400
    assert response.json()["detail"] == {
        "events[0].compartment": ["required for compartment_locked"]
    }


def test_operators_export_the_custody_chain_of_a_date_range_as_csv(locking, site, operator):
    task = request(site, secure=True, contents="Morphine")
    task_allocate(task_id=task.pk)
    Beater(locking).beat(events=[event("loaded", task.code, 0, compartment="A")])
    client = Client()
    client.force_login(operator)
    today = timezone.localdate(task.created_at).isoformat()

    response = client.get(f"/custody.csv?from={today}&to={today}")

    assert response.status_code == 200
    assert response["Content-Type"].startswith("text/csv")
    [header, row] = list(csv.reader(io.StringIO(response.content.decode())))
    assert header[:6] == ["task", "contents", "sender", "receiver", "requester", "hand-off"]
    assert (row[0], row[1], row[5], row[7], row[9]) == (
        task.code,
        "Morphine",
        "Loaded",
        "R2",
        "A",
    )
    bad = client.get("/custody.csv?from=2026-13-01&to=2026-11-01")
    assert bad.status_code == 400
    assert bad.json() == {
        "error": "invalid",
        "detail": {"from": ["a date as YYYY-MM-DD, not '2026-13-01'"]},
    }
    earlier = client.get("/custody.csv?from=2026-11-02&to=2026-11-01")
    assert earlier.json()["detail"] == {"to": ["is before from"]}


def test_nurses_may_not_export_custody(site, nurse):
    client = Client()
    client.force_login(nurse)

    assert client.get("/custody.csv?from=2026-11-01&to=2026-11-02").status_code == 403


# --- Badges of the receiving unit's users ---------------------------------------------------

WARD_BADGE = "04:A2:19:C3:7F:5E:80"


def _unit(user, site, station: str, badge: str) -> SiteMembership:
    membership = SiteMembership.objects.get(user=user, site=site)
    membership.unit = Waypoint.objects.get(site=site, code=station)
    membership.save(update_fields=["unit"])
    membership_badge_set(membership=membership, badge=badge)
    return membership


def test_the_plan_carries_the_hashed_badges_of_the_receiving_units_users(locking, site, nurse):
    _unit(nurse, site, "3F-WARD", WARD_BADGE)
    lab = factories.user_create("lee", "nurse")
    _unit(lab, site, "2F-LAB", "04:FF:00:11:22:33:44")
    task = request(site, secure=True, dropoffs=("3F-WARD",))
    assert task_allocate(task_id=task.pk)

    [plan] = plans(Beater(locking).beat())

    secure = plan["tasks"][task.code]["secure"]
    assert [entry["holder"] for entry in secure["badges"]] == ["kim"]  # not the lab's
    assert badge_check(WARD_BADGE, secure) == "kim"
    assert badge_check("04:FF:00:11:22:33:44", secure) is None
    assert WARD_BADGE not in str(plan)
    assert WARD_BADGE not in str(SiteMembership.objects.values())  # only its hash is kept


def test_the_custody_record_names_who_opened_with_a_badge(locking, site, nurse):
    _unit(nurse, site, "3F-WARD", WARD_BADGE)
    task = request(site, secure=True, dropoffs=("3F-WARD",))
    task_allocate(task_id=task.pk)
    beater = Beater(locking)
    beater.beat(events=[event("loaded", task.code, 0, compartment="A")])
    opened = event("unloaded", task.code, 1, compartment="A", opened_with="badge", opened_by="kim")
    beater.beat(events=[opened], floor="3F", waypoint="3F-WARD")

    entry = CustodyEntry.objects.get(kind="unloaded")
    assert (entry.opened_with, entry.opened_by) == ("badge", "kim")
    assert "Handed over at Ward 3 from compartment A, opened with a badge (kim)" in set(
        task.history.values_list("note", flat=True)
    )


def test_admins_set_a_users_unit_and_badge_and_only_its_hash_is_kept(site, nurse, admin_client):
    membership = SiteMembership.objects.get(user=nurse, site=site)
    ward = Waypoint.objects.get(site=site, code="3F-WARD")
    url = f"/admin/robots/sitemembership/{membership.pk}/change/"
    body = {"user": nurse.pk, "site": site.pk, "unit": ward.pk, "badge": WARD_BADGE}

    response = admin_client.post(url, body)

    assert response.status_code == 302, response.content.decode()[:2000]
    membership.refresh_from_db()
    assert membership.unit == ward
    assert membership.badge is not None
    assert badge_matches(WARD_BADGE, membership.badge)
    admin_client.post(url, {**body, "badge": ""})  # left empty: kept
    membership.refresh_from_db()
    assert membership.badge_hash
    hall = Waypoint.objects.get(site=site, code="1F-HALL")
    refused = admin_client.post(url, {**body, "unit": hall.pk})
    assert refused.status_code == 200  # not a station: the form says so
    membership.refresh_from_db()
    assert membership.unit == ward
