"""Each kind of action, done through its real interface (pages, the admin, FHIR), leaves one
audit entry with the right actor, object and change."""

from django.contrib.auth.models import Group
from django.test import Client
from django.utils import timezone

from audit.choices import Kind
from fhir_r4.models import Order
from resources.models import Lease
from robots.models import Resource
from scheduling.models import Task
from tests import factories
from tests.audit.conftest import entries, logged_in, newest_id, only_entry
from tests.factories import PASSWORD, lease_acquire, lease_enter
from tests.fhir.conftest import integration_create, ordered_task
from tests.ui.test_deliveries import order

ADDRESS = "127.0.0.1"  # the test client's, with no proxy in front (TRUSTED_PROXY_COUNT=1)


def test_it_records_a_sign_in_its_failures_and_the_sign_out(nurse):
    client = Client()
    client.post("/accounts/login/", {"username": "kim", "password": "wrong"})
    client.post("/accounts/login/", {"username": "kim", "password": PASSWORD})
    client.post("/accounts/logout/")

    failed = only_entry(Kind.SIGN_IN_FAILED)
    assert (failed.actor, failed.object_repr, failed.remote_addr) == (None, "kim", ADDRESS)
    signed_in, signed_out = only_entry(Kind.SIGN_IN), only_entry(Kind.SIGN_OUT)
    assert (signed_in.actor, signed_in.object_pk, signed_in.remote_addr) == (
        nurse,
        str(nurse.pk),
        ADDRESS,
    )
    assert (signed_out.actor_name, signed_out.remote_addr) == ("kim", ADDRESS)


def test_it_records_a_lock_out(nurse, settings):
    client = Client()
    for _ in range(settings.AXES_FAILURE_LIMIT):
        client.post("/accounts/login/", {"username": "kim", "password": "wrong"})

    locked = only_entry(Kind.LOCKED_OUT)
    assert (locked.object_repr, locked.remote_addr) == ("kim", ADDRESS)


def test_it_records_who_made_a_nurse_an_operator_in_the_admin(nurse):
    root = factories.staff_create("root", is_superuser=True)
    operators = Group.objects.get_or_create(name="operator")[0]
    nurses = Group.objects.get(name="nurse")
    joined = timezone.localtime(nurse.date_joined)
    before = newest_id()

    response = logged_in(root).post(
        f"/admin/auth/user/{nurse.pk}/change/",
        {
            "username": "kim",
            "first_name": "Kim",
            "is_active": "on",
            "groups": [nurses.pk, operators.pk],
            "date_joined_0": joined.strftime("%Y-%m-%d"),
            "date_joined_1": joined.strftime("%H:%M:%S"),
            "account-TOTAL_FORMS": "0",
            "account-INITIAL_FORMS": "0",
        },
    )

    assert response.status_code == 302, response.context["errors"]
    change = only_entry(Kind.CHANGE, id__gt=before, changes__has_key="groups")
    assert change.actor == root
    assert change.changes["groups"] == {
        "type": "m2m",
        "operation": "add",
        "objects": ["operator"],
    }
    assert change.remote_addr == ADDRESS


def test_it_records_a_robot_token_issued_in_the_admin(robot):
    root = factories.staff_create("root", is_superuser=True)
    before = newest_id()

    logged_in(root).post(
        "/admin/robots/robot/", {"action": "issue_token", "_selected_action": [robot.pk]}
    )

    issued = only_entry(Kind.TOKEN_ISSUED, id__gt=before)
    assert (issued.actor, issued.object_repr, issued.site_id) == (root, str(robot), robot.site_id)


def test_it_records_an_order_and_its_cancel_from_the_pages(nurse, site):
    client = logged_in(nurse)
    order(client)
    task = Task.objects.get()
    client.post(f"/deliveries/{task.code}/cancel")

    ordered = only_entry(Kind.TASK_ORDERED)
    assert (ordered.actor, ordered.object_repr, ordered.site_id) == (nurse, task.code, site.pk)
    assert ordered.additional_data["cause"] == "request"
    cancelled = only_entry(Kind.TASK_CANCELLED)
    assert (cancelled.actor, cancelled.object_repr) == (nurse, task.code)
    assert cancelled.changes == {"status": ["due", "cancelled"]}
    assert cancelled.remote_addr == ADDRESS


def test_it_records_an_operators_pause_of_a_robot(operator, robot):
    logged_in(operator).post(f"/robots/{robot.code}/action", {"action": "pause"})

    action = only_entry(Kind.OPERATOR_ACTION)
    assert (action.actor, action.object_pk, action.site_id) == (
        operator,
        str(robot.pk),
        robot.site_id,
    )
    assert action.additional_data["action"] == "pause"


def test_it_records_a_forced_release_of_a_lift(operator, site):
    robot = factories.robot_create(site, "R1")
    elevator = Resource.objects.get(code="ELEV")
    inside = lease_acquire(robot=robot, resource=elevator, request_id="q-1", to_floor="2F")
    lease_enter(robot=robot, resource=elevator)

    logged_in(operator).post(f"/leases/{inside.public_id}/release")

    released = only_entry(Kind.LEASE_FORCE_RELEASED)
    assert released.actor == operator
    assert released.object_repr == f"{inside.public_id}: R1 on ELEV"
    assert released.changes == {"state": ["entered", Lease.objects.get(pk=inside.pk).state]}


def test_it_records_a_custody_export(operator, site):
    today = timezone.localdate().isoformat()

    logged_in(operator).get(f"/custody.csv?from={today}&to={today}")

    exported = only_entry(Kind.CUSTODY_EXPORTED)
    assert (exported.actor, exported.site_id) == (operator, site.pk)
    assert exported.additional_data == {"from": today, "to": today, "rows": 0}


def test_it_records_reads_of_patient_linked_orders_over_fhir_and_on_the_page(site, operator):
    pharmacy = integration_create("pharmacy-system", sites=[site])
    fhir = Client(headers={"Authorization": f"Bearer {pharmacy.api_token_plain}"})
    fhir_json = "application/fhir+json"
    created = fhir.post("/fhir/r4/Task", ordered_task(), content_type=fhir_json)
    assert created.status_code == 201, created.content
    code = created.json()["id"]

    fhir.get(f"/fhir/r4/Task/{code}")
    fhir.get("/fhir/r4/Task")
    logged_in(operator).get(f"/deliveries/{code}/")

    assert Order.objects.get().task.code == code
    ordered = only_entry(Kind.TASK_ORDERED)
    assert (ordered.actor, ordered.object_repr) == (pharmacy, code)
    reads = entries(Kind.ORDER_READ)
    assert [(read.actor, read.additional_data["via"]) for read in reads] == [
        (pharmacy, "FHIR read"),  # the answer to the order
        (pharmacy, "FHIR read"),
        (pharmacy, "FHIR search"),
        (operator, "delivery page"),
    ]
    assert {read.object_repr for read in reads} == {code}
    assert {read.site_id for read in reads} == {site.pk}


def test_it_tells_a_person_and_the_admin_the_previous_sign_in_and_failures_since(site, nurse):
    client, login = Client(), "/accounts/login/"
    first = client.post(login, {"username": "kim", "password": PASSWORD}, follow=True)
    client.post("/accounts/logout/")
    client.post(login, {"username": "kim", "password": "wrong"})
    again = client.post(login, {"username": "kim", "password": PASSWORD}, follow=True)

    earlier, latest = (timezone.localtime(e.timestamp) for e in entries(Kind.SIGN_IN))
    assert "No earlier sign-in is recorded." in first.content.decode()
    assert (
        f"Last signed in on {earlier:%Y-%m-%d %H:%M} from {ADDRESS}. "
        "Failed sign-ins with this user name since: 1."
    ) in again.content.decode()
    root = logged_in(factories.staff_create("root", is_superuser=True))
    admin_page = root.get(f"/admin/auth/user/{nurse.pk}/change/").content.decode()
    assert f"Last signed in on {latest:%Y-%m-%d %H:%M} from {ADDRESS}.<" in admin_page
