"""Operators work from the pages: force-release a stuck lease, confirm risky actions."""

from django.contrib.messages import get_messages

from resources.models import Lease
from robots.models import Resource
from scheduling.services import task_allocate
from tests import factories
from tests.factories import lease_acquire, lease_enter
from tests.scheduling.conftest import Beater, event, request, robot_ready


def elevator():
    return Resource.objects.get(code="ELEV")


def test_an_operator_force_releases_a_stuck_lease_and_the_next_robot_gets_it(operator_client, site):
    r1, r2 = (factories.robot_create(site, code) for code in ("R1", "R2"))
    inside = lease_acquire(robot=r1, resource=elevator(), request_id="q-1", to_floor="2F")
    lease_enter(robot=r1, resource=elevator())
    waiting = lease_acquire(robot=r2, resource=elevator(), request_id="q-2", to_floor="3F")

    html = operator_client.get(f"/fleet/?site={site.code}").content.decode()
    assert f'action="/leases/{inside.public_id}/release"' in html
    assert "R1 may still be inside" in html  # the page asks first

    response = operator_client.post(f"/leases/{inside.public_id}/release")

    assert response.status_code == 302
    inside.refresh_from_db()
    waiting.refresh_from_db()
    assert (inside.state, waiting.state) == ("revoked", "granted")
    [message] = [str(m) for m in get_messages(response.wsgi_request)]
    assert message == "ELEV (R1) force-released. Now granted to R2."
    again = operator_client.post(f"/leases/{inside.public_id}/release", follow=True)
    assert "had already been released" in again.content.decode()


def test_nurses_may_not_force_release_and_unknown_leases_are_404(
    nurse_client, operator_client, site
):
    robot = factories.robot_create(site, "R1")
    lease = lease_acquire(robot=robot, resource=elevator(), request_id="q-1", to_floor="2F")

    assert nurse_client.post(f"/leases/{lease.public_id}/release").status_code == 403
    assert "Force-release" not in nurse_client.get(f"/fleet/?site={site.code}").content.decode()
    assert operator_client.post("/leases/L-999999/release").status_code == 404
    assert operator_client.post("/leases/nonsense/release").status_code == 404
    assert Lease.objects.get().state == "granted"


def test_cancelling_after_pick_up_asks_first_and_says_the_items_come_back(
    nurse_client, nurse, site
):
    robot = robot_ready(factories.robot_create(site, "R1"))
    waiting = request(site, user=nurse, contents="Insulin")
    loaded = request(site, user=nurse, contents="Blood")
    for task in (waiting, loaded):
        task_allocate(task_id=task.pk)
    Beater(robot).beat(events=[event("loaded", loaded.code, 0)])

    html = nurse_client.get("/").content.decode()

    assert html.count("data-confirm=") == 1
    assert f"Cancel {loaded.code}? Its items are already on board" in html
    assert "bring them back to Pharmacy" in html


def test_the_form_limits_text_inputs_as_the_server_does(nurse_client, site):
    html = nurse_client.get("/").content.decode()

    for name in ("sender", "receiver", "contents"):
        assert f'name="{name}" maxlength="200"' in html
