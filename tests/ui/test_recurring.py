"""Periodic requests on their page: nurses see and stop their own, operators anyone's."""

from django.contrib.messages import get_messages

from scheduling.models import RecurringRequest, Task
from tests.scheduling.conftest import request


def series(site, user, contents, times=("08:00",)):
    request(site, user=user, contents=contents, repeat={"times": list(times)})
    return RecurringRequest.objects.get(contents=contents)


def test_nurses_see_their_own_series_and_operators_everyones(
    nurse_client, operator_client, nurse, other_nurse, site
):
    series(site, nurse, "Insulin", times=("08:00", "14:00"))
    series(site, other_nurse, "Gauze")

    mine = nurse_client.get(f"/recurring/?site={site.code}").content.decode()
    everyone = operator_client.get(f"/recurring/?site={site.code}").content.decode()

    assert "Insulin" in mine
    assert "every day at 08:00, 14:00" in mine
    assert "Gauze" not in mine
    assert "Insulin" in everyone
    assert "Gauze" in everyone
    assert 'data-confirm="Stop “Insulin”' in mine


def test_stopping_a_series_cancels_its_upcoming_deliveries_once(nurse_client, nurse, site):
    recurring = series(site, nurse, "Insulin")
    upcoming = recurring.instances.get()
    assert upcoming.status == "scheduled"

    response = nurse_client.post(f"/recurring/{recurring.pk}/stop")

    assert response.status_code == 302
    recurring.refresh_from_db()
    upcoming.refresh_from_db()
    assert (recurring.active, upcoming.status) == (False, "cancelled")
    assert [str(m) for m in get_messages(response.wsgi_request)] == [
        "Stopped: Insulin; 1 upcoming cancelled."
    ]
    again = nurse_client.post(f"/recurring/{recurring.pk}/stop", follow=True)
    assert "had already been stopped" in again.content.decode()
    assert Task.objects.filter(status="cancelled").count() == 1


def test_a_nurse_may_not_stop_someone_elses_series(nurse_client, other_nurse, site):
    recurring = series(site, other_nurse, "Gauze")

    assert nurse_client.post(f"/recurring/{recurring.pk}/stop").status_code == 403
    recurring.refresh_from_db()
    assert recurring.active
    assert nurse_client.post("/recurring/99999/stop").status_code == 404
