"""The reports page and its CSV exports (managers), and /metrics (operations' Prometheus).

Thin views: the figures come from reports/rollups.py (over reports/selectors.py) and
reports/monitoring.py.
"""

import hmac
from urllib.parse import urlencode

from django.conf import settings
from django.http import Http404, HttpResponse, JsonResponse
from django.shortcuts import render
from django.utils import timezone
from django.views.decorators.http import require_GET
from prometheus_client import CONTENT_TYPE_LATEST

from core.access import is_operator, operator_required
from core.csvsafe import csv_writer
from reports.forms import ReportForm
from reports.metrics import exposition
from reports.rollups import period_figures
from reports.selectors import Period
from reports.tables import BY_KEY, TABLES, series_label
from robots.membership import member_site_codes, site_chosen


@require_GET
def metrics(request):
    """Prometheus scrapes this with `Authorization: Bearer $METRICS_TOKEN` (every site's
    series); staff read it with their login too, operators the series of their own sites."""
    if _token_valid(request):
        sites = None
    elif is_operator(request.user):
        sites = member_site_codes(request.user)  # staff: None, every site
    else:
        return _refused(request)
    body = exposition(now=timezone.now(), sites=sites)
    return HttpResponse(body, content_type=CONTENT_TYPE_LATEST)


def _token_valid(request) -> bool:
    scheme, _, token = request.headers.get("Authorization", "").partition(" ")
    expected = settings.METRICS_TOKEN
    return bool(expected) and scheme == "Bearer" and hmac.compare_digest(token, expected)


def _refused(request) -> JsonResponse:
    if request.user.is_authenticated and not request.headers.get("Authorization"):
        why = {"user": ["only operators and staff may read the metrics"]}
        return JsonResponse({"error": "forbidden", "detail": why}, status=403)
    why = {"Authorization": ["a valid METRICS_TOKEN bearer token, or an operator's login"]}
    response = JsonResponse({"error": "unauthorized", "detail": why}, status=401)
    response["WWW-Authenticate"] = 'Bearer realm="metrics"'
    return response


@operator_required
@require_GET
def reports_page(request):
    """Charts, each with its table beside it and a CSV link, for a site and a date range."""
    form = _form(request)
    if not form.is_valid():
        return render(request, "reports/reports.html", {"form": form}, status=400)
    period = _period(form)
    now = timezone.now()
    figures = period_figures(period, now=now)  # once, for every table
    sections = [
        _section(table, table.compute(period, now=now, figures=figures)) for table in TABLES
    ]
    context = {"form": form, "period": period, "sections": sections, "query": _query(period)}
    return render(request, "reports/reports.html", context)


@operator_required
@require_GET
def report_csv(request, table: str):
    """The rows behind one table, as CSV (same keys, same order)."""
    chosen = BY_KEY.get(table)
    if chosen is None:
        detail = {"table": [f"unknown table (use one of {', '.join(BY_KEY)})"]}
        return JsonResponse({"error": "not_found", "detail": detail}, status=404)
    try:
        form = _form(request)
    except Http404:
        detail = {"site": ["no such site of yours"]}
        return JsonResponse({"error": "not_found", "detail": detail}, status=404)
    if not form.is_valid():
        detail = {name: [str(e) for e in errors] for name, errors in form.errors.items()}
        return JsonResponse({"error": "invalid", "detail": detail}, status=400)
    period = _period(form)
    rows = chosen.compute(period, now=timezone.now())
    response = HttpResponse(content_type="text/csv; charset=utf-8")
    name = f"{period.site.code}-{chosen.key}-{period.first}-{period.last}.csv"
    response["Content-Disposition"] = f'attachment; filename="{name}"'
    writer = csv_writer(response)
    writer.writerow([key for key, _ in chosen.columns])
    for row in rows:
        writer.writerow(["" if row.get(key) is None else row.get(key) for key, _ in chosen.columns])
    return response


def _form(request) -> ReportForm:
    """The report's form over the user's sites: another site's code answers 404, as every
    page does (robots/membership.py)."""
    _site, sites = site_chosen(request.user, request.GET.get("site"))
    return ReportForm(request.GET, sites=sites)


def _period(form) -> Period:
    data = form.cleaned_data
    return Period(site=data["site"], first=data["date_from"], last=data["date_to"])


def _query(period: Period) -> str:
    return urlencode({"site": period.site.code, "date_from": period.first, "date_to": period.last})


def _section(table, rows: list[dict]) -> dict:
    return {
        "table": table,
        "cells": [[row.get(key) for key, _ in table.columns] for row in rows],
        "data_id": f"data-{table.key}",
        "chart": {**_chart(table), "rows": rows},
    }


def _chart(table) -> dict:
    return {
        "type": table.chart,
        "label": table.label,
        "stacked": table.stacked,
        "series": [{"key": key, "label": series_label(table, key)} for key in table.series],
    }
