from django import forms
from django.utils import timezone
from django.utils.translation import gettext_lazy as _

from audit.choices import Kind
from core.dates import date_out_of_range

MAX_EXPORT_DAYS = 366


class EntryFilterForm(forms.Form):
    """The auditors' filters; `sites` are those the reader may see. An export needs both days
    and at most MAX_EXPORT_DAYS of them."""

    person = forms.CharField(required=False, max_length=150, label=_("Person (user name)"))
    site = forms.ChoiceField(required=False, label=_("Site"))
    kind = forms.ChoiceField(required=False, label=_("What"), choices=[("", _("anything"))])
    start = forms.DateField(required=False, label=_("From"))
    end = forms.DateField(required=False, label=_("To"))

    def __init__(self, data, *, sites, export: bool = False):
        super().__init__(data)
        self.sites = {site.code: site for site in sites}
        self.export = export
        self.fields["site"].choices = [("", "all my sites")] + [
            (code, str(site)) for code, site in self.sites.items()
        ]
        self.fields["kind"].choices = [("", "anything"), *Kind.choices]
        if export:
            self.fields["start"].required = self.fields["end"].required = True

    def clean_site(self):
        code = self.cleaned_data["site"]
        return self.sites[code] if code else None

    def clean(self):
        cleaned = super().clean()
        today = timezone.localdate()
        for name in ("start", "end"):
            day = cleaned.get(name)
            why = date_out_of_range(day, today=today) if day else None
            if why:
                self.add_error(name, why)
        start, end = cleaned.get("start"), cleaned.get("end")
        if start and end and end < start:
            self.add_error("end", _("is before From"))
        elif self.export and start and end and (end - start).days >= MAX_EXPORT_DAYS:
            self.add_error("end", _("at most %(days)d days after From") % {"days": MAX_EXPORT_DAYS})
        return cleaned

    def filters(self) -> dict:
        return {name: self.cleaned_data[name] or None for name in self.fields} | {
            "person": self.cleaned_data["person"],
            "kind": self.cleaned_data["kind"],
        }
