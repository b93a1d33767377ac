from datetime import timedelta

from django import forms
from django.utils import timezone
from django.utils.translation import gettext_lazy as _

from core.dates import date_out_of_range
from robots.models import Site

LONGEST = timedelta(days=400)
DEFAULT_DAYS = 30


class ReportForm(forms.Form):
    """Which site (of `sites`, the user's) and which days (inclusive, in the site's time
    zone)."""

    site = forms.ModelChoiceField(
        queryset=Site.objects.none(), to_field_name="code", required=False
    )
    date_from = forms.DateField(required=False, label=_("From"))
    date_to = forms.DateField(required=False, label=_("To"))

    def __init__(self, *args, sites: list[Site], **kwargs):
        super().__init__(*args, **kwargs)
        self.sites = sites
        ids = [site.pk for site in sites]
        self.fields["site"].queryset = Site.objects.filter(pk__in=ids).order_by("code")

    def clean_date_from(self):
        return self._bounded("date_from")

    def clean_date_to(self):
        return self._bounded("date_to")

    def _bounded(self, name: str):
        value = self.cleaned_data.get(name)
        if value is not None:
            why = date_out_of_range(value, today=timezone.localdate())
            if why:
                raise forms.ValidationError(why)
        return value

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
            self.add_error("date_from", _("must not be after To"))
        elif data["date_to"] - data["date_from"] > LONGEST:
            self.add_error(
                "date_from", _("a report covers at most %(days)d days") % {"days": LONGEST.days}
            )
        if data.get("site") is None:
            data["site"] = self.sites[0]
        return data
