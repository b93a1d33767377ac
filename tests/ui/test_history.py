"""A task's history: every transition with its time and cause, as a page or the table's dialog."""

from django.utils import timezone

from scheduling.services import task_cancel
from tests.scheduling.conftest import request


def test_it_shows_every_transition_with_time_and_cause(nurse_client, nurse, site):
    task = request(site, user=nurse)
    task_cancel(task=task, by=nurse)

    html = nurse_client.get(f"/deliveries/{task.code}/").content.decode()

    assert f"Delivery {task.code}" in html
    assert "<strong>Due, waiting for a robot</strong>" in html  # created due
    assert "Due, waiting for a robot → <strong>Cancelled</strong>" in html
    assert "Requested" in html
    assert "User" in html
    for entry in task.history.all():
        assert timezone.localtime(entry.at).strftime("%H:%M:%S") in html
    assert "Pharmacy" in html
    assert "Laboratory" in html


def test_it_serves_the_history_alone_for_the_tables_dialog(nurse_client, site):
    task = request(site)

    html = nurse_client.get(f"/deliveries/{task.code}/?partial=1").content.decode()

    assert html.lstrip().startswith('<div class="task-history"')
    assert "<html" not in html


def test_it_links_each_row_of_the_schedule_to_its_history(nurse_client, site):
    task = request(site)

    html = nurse_client.get("/").content.decode()

    assert f'<a href="/deliveries/{task.code}/" data-history>{task.code}</a>' in html


def test_it_answers_404_for_an_unknown_task(nurse_client, site):
    assert nurse_client.get("/deliveries/T-9999/").status_code == 404
