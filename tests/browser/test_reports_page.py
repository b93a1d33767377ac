"""The reports page in Chromium: a chart drawn for every table from a seeded history, and each
CSV export holding the rows the table shows."""

import csv
import io
from datetime import timedelta

import pytest
from django.utils import timezone
from playwright.sync_api import expect

from reports.seed import history_seed
from scheduling.models import Task
from tests import factories

pytestmark = pytest.mark.browser

TABLES = [
    "per_day",
    "per_hour",
    "by_priority",
    "by_ward",
    "utilisation",
    "resource_waits",
    "failures",
]


@pytest.fixture
def history(site):
    for code in ("R1", "R2", "R3"):
        factories.robot_create(site, code)
    return history_seed(site=site, deliveries=800, days=15, end=timezone.now(), seed=5)


def test_it_draws_every_chart_beside_its_table_and_the_csv_matches_it(
    open_page, operator, history, site
):
    # Days that are over: today's utilisation grows while the page and its CSVs are read.
    today = timezone.localdate()
    first, last = today - timedelta(days=14), today - timedelta(days=1)
    query = f"site={site.code}&date_from={first}&date_to={last}"
    page = open_page(operator, f"/reports/?{query}", live=False)

    for key in TABLES:
        section = page.locator(f'[data-report="{key}"]')
        expect(section).to_have_attribute("data-chart", "drawn")
        drawn = page.evaluate(
            """key => {
                const chart = Chart.getChart(document.getElementById("chart-" + key));
                return {labels: chart.data.labels.length,
                        points: chart.data.datasets.map(d => d.data.length)};
            }""",
            key,
        )
        table = page.locator(f"#table-{key} tbody tr")
        assert drawn["labels"] == table.count(), key
        assert all(points == drawn["labels"] for points in drawn["points"]), key

        href = section.locator("a.csv-link").get_attribute("href")
        body = page.evaluate("href => fetch(href).then(r => r.text())", href)
        rows = list(csv.reader(io.StringIO(body)))[1:]
        cells = page.locator(f"#table-{key} tbody tr").evaluate_all(
            "rows => rows.map(r => [...r.cells].map(c => c.textContent.trim()))"
        )
        assert rows == cells, key

    days = page.evaluate("Chart.getChart(document.getElementById('chart-per_day')).data")
    assert len(days["labels"]) == 14
    midnight = timezone.localtime().replace(hour=0, minute=0, second=0, microsecond=0)
    requested = Task.objects.filter(
        requested_time__gte=midnight - timedelta(days=14), requested_time__lt=midnight
    )
    assert sum(days["datasets"][0]["data"]) == requested.count() > 600
