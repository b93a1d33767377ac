"""The admin's users show where each comes from (local, LDAP directory, single sign-on) and let
an administrator set a person's workstation PIN; workstations are bound to a site and unit."""

from django import forms
from django.contrib import admin
from django.contrib.auth import get_user_model
from django.contrib.auth.admin import UserAdmin
from django.core.exceptions import ValidationError

from accounts.choices import Source
from accounts.models import Account, Workstation
from accounts.services import account_pin_set, pin_validate
from audit.receivers import sign_ins_words
from audit.selectors import sign_ins_of

User = get_user_model()


class AccountForm(forms.ModelForm):
    """The PIN is typed here and only its salted hash is kept."""

    pin = forms.CharField(
        label="New workstation PIN",
        required=False,
        strip=True,
        widget=forms.PasswordInput(render_value=False, attrs={"autocomplete": "new-password"}),
        help_text="4 to 8 digits, confirmed with the badge at a shared workstation; left empty, "
        "the current one stays",
    )
    forget_pin = forms.BooleanField(label="Remove the PIN", required=False)

    class Meta:
        model = Account
        fields = []

    def clean_pin(self):
        pin = self.cleaned_data["pin"]
        if pin:
            try:
                pin_validate(pin)
            except ValidationError as invalid:
                raise ValidationError(invalid.message_dict["pin"]) from None
        return pin


class AccountInline(admin.StackedInline):
    model = Account
    form = AccountForm
    can_delete = False
    max_num = 1
    verbose_name = verbose_name_plural = "sign-in"
    readonly_fields = ["source", "subject", "synced_at", "has_pin"]
    fields = ["source", "subject", "synced_at", "has_pin", "pin", "forget_pin"]

    @admin.display(boolean=True, description="workstation PIN set")
    def has_pin(self, account) -> bool:
        return bool(account.pin_hash)


admin.site.unregister(User)  # Django's, registered by django.contrib.auth (listed before us)


@admin.register(User)
class HospitalUserAdmin(UserAdmin):
    inlines = [*UserAdmin.inlines, AccountInline]
    list_display = [*UserAdmin.list_display, "source"]
    list_filter = [*UserAdmin.list_filter, "account__source"]
    list_select_related = ["account"]
    readonly_fields = [*UserAdmin.readonly_fields, "sign_ins"]

    def get_fieldsets(self, request, obj=None):
        fieldsets = super().get_fieldsets(request, obj)
        if obj is None:
            return fieldsets
        return [*fieldsets, ("Sign-ins (audit trail)", {"fields": ["sign_ins"]})]

    @admin.display(description="previous sign-in and failures since")
    def sign_ins(self, user) -> str:
        return sign_ins_words(sign_ins_of(user))

    @admin.display(description="signs in with", ordering="account__source")
    def source(self, user) -> str:
        account = getattr(user, "account", None)
        return account.get_source_display() if account else Source.LOCAL.label

    def save_formset(self, request, form, formset, change):
        super().save_formset(request, form, formset, change)
        if formset.model is not Account:
            return
        for account_form in formset.forms:
            pin = account_form.cleaned_data.get("pin")
            if pin or account_form.cleaned_data.get("forget_pin"):
                account_pin_set(user=form.instance, pin=pin or "")


@admin.register(Workstation)
class WorkstationAdmin(admin.ModelAdmin):
    """A shared PC at a ward: make a local user for it first (no group, no staff status), then
    bind it here; sign in on the PC as that user once, and it stays signed in."""

    list_display = ["name", "user", "site", "unit"]
    list_filter = ["site"]
    search_fields = ["name", "user__username"]
    autocomplete_fields = ["user"]
    list_select_related = ["user", "site", "unit"]
