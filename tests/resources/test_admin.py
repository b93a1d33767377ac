"""Admin: leases with their queue positions, force-release, and a resource's live queue."""

import pytest
from django.contrib.messages import get_messages
from django.test import Client

from resources.models import Lease
from tests import factories
from tests.factories import lease_acquire, lease_enter
from tests.resources.conftest import holders, resource


@pytest.fixture
def admin_client(db):
    client = Client()
    client.force_login(factories.staff_create("admin", is_superuser=True))
    return client


@pytest.fixture
def elevator_queue(site):
    """R1 inside the elevator, R2 and R3 waiting in that order."""
    leases = []
    for code in ("R1", "R2", "R3"):
        robot = factories.robot_create(site, code)
        leases.append(
            lease_acquire(
                robot=robot, resource=resource("ELEV"), request_id=f"q-{code}", to_floor="2F"
            )
        )
    lease_enter(robot=leases[0].robot, resource=resource("ELEV"))
    return leases


def test_it_shows_queue_positions_in_the_lease_list(admin_client, elevator_queue):
    response = admin_client.get("/admin/resources/lease/?state__exact=queued")

    assert response.status_code == 200
    rows = [(lease.public_id, lease.queue_position) for lease in response.context["cl"].result_list]
    assert rows == [(elevator_queue[1].public_id, 1), (elevator_queue[2].public_id, 2)]


def test_it_lists_a_resources_live_leases_in_queue_order(admin_client, elevator_queue):
    response = admin_client.get(f"/admin/robots/resource/{resource('ELEV').pk}/change/")

    assert response.status_code == 200
    inline = next(f for f in response.context["inline_admin_formsets"] if f.opts.model is Lease)
    listed = [form.original.public_id for form in inline]
    assert listed == [lease.public_id for lease in elevator_queue]


def test_it_force_releases_from_the_admin_and_grants_the_next_in_line(
    admin_client, elevator_queue, django_capture_on_commit_callbacks
):
    inside = elevator_queue[0]

    with django_capture_on_commit_callbacks(execute=True):
        response = admin_client.post(
            "/admin/resources/lease/",
            {"action": "force_release", "_selected_action": [inside.pk]},
            follow=True,
        )

    assert [str(m) for m in get_messages(response.wsgi_request)] == [
        f"Force-released {inside.public_id} (R1 on ELEV); "
        f"granted {elevator_queue[1].public_id} to R2."
    ]
    inside.refresh_from_db()
    assert (inside.state, inside.ended_by.username) == ("revoked", "admin")
    assert holders("ELEV") == ["R2"]


def test_it_allows_no_editing_adding_or_deleting_of_leases_in_the_admin(
    admin_client, elevator_queue
):
    lease = elevator_queue[1]

    page = admin_client.get(f"/admin/resources/lease/{lease.pk}/change/")
    admin_client.post(f"/admin/resources/lease/{lease.pk}/change/", {"state": "granted"})

    assert page.status_code == 200
    assert b'name="_save"' not in page.content
    assert admin_client.get("/admin/resources/lease/add/").status_code == 403
    assert admin_client.get(f"/admin/resources/lease/{lease.pk}/delete/").status_code == 403
    lease.refresh_from_db()
    assert lease.state == "queued"
