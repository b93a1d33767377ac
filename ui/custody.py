"""The chain of custody of secure deliveries as CSV, for a date range: the pharmacy's audit."""

from datetime import date, datetime, time, timedelta

from django.http import HttpResponse, JsonResponse
from django.utils import timezone

from audit.services import custody_export_record
from core.access import operator_required
from core.csvsafe import csv_writer
from core.dates import date_out_of_range
from scheduling.selectors import custody_between
from ui.selectors import page_site

COLUMNS = [
    "task",
    "contents",
    "sender",
    "receiver",
    "requester",
    "hand-off",
    "at",
    "robot",
    "station",
    "compartment",
    "opened with",
    "opened by",
    "wrong PINs before",
]
MAX_DAYS = 366


@operator_required
def custody_csv(request):
    """GET ?from=YYYY-MM-DD&to=YYYY-MM-DD (both days included, the site's time zone)."""
    site, _sites = page_site(request)
    errors, days = _days(request.GET)
    if errors:
        return JsonResponse({"error": "invalid", "detail": errors}, status=400)
    start, end = days
    zone = timezone.get_current_timezone()
    entries = list(
        custody_between(
            site=site,
            start=datetime.combine(start, time.min, zone),
            end=datetime.combine(end + timedelta(days=1), time.min, zone),
        )
    )
    custody_export_record(site=site, start=start, end=end, rows=len(entries))
    response = HttpResponse(content_type="text/csv; charset=utf-8")
    name = f"custody-{site.code}-{start:%Y%m%d}-{end:%Y%m%d}.csv"
    response["Content-Disposition"] = f'attachment; filename="{name}"'
    writer = csv_writer(response)
    writer.writerow(COLUMNS)
    writer.writerows(_row(entry) for entry in entries)
    return response


def _days(query) -> tuple[dict, tuple[date, date] | None]:
    errors, found = {}, {}
    for name in ("from", "to"):
        raw = query.get(name, "")
        try:
            found[name] = date.fromisoformat(raw)
        except ValueError:
            errors[name] = [f"a date as YYYY-MM-DD, not {raw[:20]!r}" if raw else "required"]
            continue
        why = date_out_of_range(found[name], today=timezone.localdate())
        if why:
            errors[name] = [why]
    if not errors and found["to"] < found["from"]:
        errors["to"] = ["is before from"]
    elif not errors and (found["to"] - found["from"]).days >= MAX_DAYS:
        errors["to"] = [f"at most {MAX_DAYS} days after from"]
    return errors, None if errors else (found["from"], found["to"])


def _row(entry) -> list:
    task = entry.task
    return [
        task.code,
        task.contents,
        task.sender,
        task.receiver,
        task.requester.get_username() if task.requester else "",
        entry.get_kind_display(),
        timezone.localtime(entry.at).isoformat(timespec="seconds"),
        entry.robot.code if entry.robot else "",
        entry.station,
        entry.compartment,
        entry.opened_with,
        entry.opened_by,
        entry.failed_attempts,
    ]
