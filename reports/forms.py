from datetime import timedelta

from django import forms
from django.utils import timezone

from robots.models import Site

LONGEST = timedelta(days=400)
DEFAULT_DAYS = 30


class ReportForm(forms.Form):
    """Which site and which days (inclusive, in the site's time zone)."""

    site = forms.ModelChoiceField(
        queryset=Site.objects.order_by("code"), to_field_name="code", required=False
    )
    date_from = forms.DateField(required=False, label="From")
    date_to = forms.DateField(required=False, label="To")

    def clean(self):
        data = super().clean()
        if self.errors:
            return data
        today = timezone.localdate()
        data["date_to"] = data.get("date_to") or today
        data["date_from"] = data.get("date_from") or data["date_to"] - timedelta(
            days=DEFAULT_DAYS - 1
        )
        if data["date_from"] > data["date_to"]:
            self.add_error("date_from", "must not be after To")
        elif data["date_to"] - data["date_from"] > LONGEST:
            self.add_error("date_from", f"a report covers at most {LONGEST.days} days")
        if data.get("site") is None:
            data["site"] = Site.objects.order_by("code").first()
            if data["site"] is None:
                self.add_error("site", "no site is loaded yet (manage.py load_site FILE)")
        return data
