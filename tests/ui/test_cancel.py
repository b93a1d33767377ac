"""Cancelling from the schedule table: nurses their own requests, operators any task."""

import re

from scheduling.models import Task
from tests.scheduling.conftest import request, status
from tests.ui.conftest import logged_in


def cancel_buttons(html: str) -> set[str]:
    return set(re.findall(r'action="/deliveries/(T-\d+)/cancel"', html))


def test_it_lets_a_nurse_cancel_her_own_request(nurse_client, nurse, site):
    task = request(site, user=nurse)

    response = nurse_client.post(f"/deliveries/{task.code}/cancel")

    assert response.status_code == 302
    assert status(task) == "cancelled"
    entry = task.history.order_by("id").last()
    assert (entry.cause, entry.user) == ("user", nurse)


def test_it_forbids_a_nurse_to_cancel_someone_elses_request(nurse_client, other_nurse, site):
    task = request(site, user=other_nurse)

    response = nurse_client.post(f"/deliveries/{task.code}/cancel")

    assert response.status_code == 403
    assert status(task) == "due"


def test_it_lets_an_operator_cancel_any_task(operator_client, other_nurse, site):
    task = request(site, user=other_nurse)

    operator_client.post(f"/deliveries/{task.code}/cancel")

    assert status(task) == "cancelled"


def test_it_offers_cancel_only_where_the_user_may(nurse, other_nurse, operator, site):
    mine, theirs = request(site, user=nurse), request(site, user=other_nurse)
    finished = request(site, user=nurse)
    Task.objects.filter(pk=finished.pk).update(status="delivered")

    assert cancel_buttons(logged_in(nurse).get("/").content.decode()) == {mine.code}
    assert cancel_buttons(logged_in(operator).get("/").content.decode()) == {
        mine.code,
        theirs.code,
    }


def test_it_explains_when_a_task_can_no_longer_be_cancelled(nurse_client, nurse, site):
    task = request(site, user=nurse)
    Task.objects.filter(pk=task.pk).update(status="delivered")

    response = nurse_client.post(f"/deliveries/{task.code}/cancel", follow=True)

    assert f"{task.code} could not be cancelled: {task.code} is delivered." in (
        response.content.decode()
    )
    assert status(task) == "delivered"


def test_it_refuses_to_cancel_with_get(nurse_client, nurse, site):
    task = request(site, user=nurse)

    assert nurse_client.get(f"/deliveries/{task.code}/cancel").status_code == 405
    assert status(task) == "due"
