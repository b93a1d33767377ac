"""The auditors' page: the audit trail of the reader's sites, filtered, and its exports.

Thin views: reads through audit/selectors.py; an export is itself audited.
"""

import json

from django.core.paginator import Paginator
from django.http import HttpResponse, JsonResponse
from django.shortcuts import render
from django.views.decorators.http import require_GET

from audit.exports import COLUMNS, entry_record, entry_row
from audit.forms import EntryFilterForm
from audit.selectors import entries_matching, entries_visible, sites_visible
from audit.services import audit_export_record
from core.access import auditor_required
from core.csvsafe import csv_writer

PAGE_SIZE = 100


@require_GET
@auditor_required
def entries_page(request):
    form = EntryFilterForm(request.GET, sites=sites_visible(request.user))
    if not form.is_valid():
        return render(request, "audit/entries.html", {"form": form}, status=400)
    entries = entries_matching(entries_visible(request.user), **form.filters())
    page = Paginator(entries, PAGE_SIZE).get_page(request.GET.get("page"))
    query = request.GET.copy()
    query.pop("page", None)
    context = {"form": form, "page": page, "listed": True, "query": query.urlencode()}
    return render(request, "audit/entries.html", context)


@require_GET
@auditor_required
def entries_export(request, extension: str):
    """GET ?start=YYYY-MM-DD&end=YYYY-MM-DD (both included) and the page's other filters:
    the matching entries as CSV or JSON, oldest first."""
    form = EntryFilterForm(request.GET, sites=sites_visible(request.user), export=True)
    if not form.is_valid():
        return JsonResponse({"error": "invalid", "detail": form.errors}, status=400)
    filters = form.filters()
    entries = list(entries_matching(entries_visible(request.user), **filters).reverse())
    audit_export_record(filters=filters, rows=len(entries), file_format=extension)
    name = f"audit-{filters['start']:%Y%m%d}-{filters['end']:%Y%m%d}.{extension}"
    if extension == "json":
        body = json.dumps([entry_record(entry) for entry in entries], indent=1)
        response = HttpResponse(body, content_type="application/json")
    else:
        response = HttpResponse(content_type="text/csv; charset=utf-8")
        writer = csv_writer(response)
        writer.writerow(COLUMNS)
        writer.writerows(entry_row(entry) for entry in entries)
    response["Content-Disposition"] = f'attachment; filename="{name}"'
    return response
