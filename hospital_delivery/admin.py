from django.contrib import admin

from hospital_delivery.models import ApiToken, SiteMembership


@admin.register(ApiToken)
class ApiTokenAdmin(admin.ModelAdmin):
    list_display = ["user", "created_at"]
    search_fields = ["user__username"]
    readonly_fields = ["user", "created_at"]

    def has_add_permission(self, request):
        return False  # issued with `manage.py user_token`, which shows the token once


@admin.register(SiteMembership)
class SiteMembershipAdmin(admin.ModelAdmin):
    """Who works at which site (staff users and superusers see every site without one)."""

    list_display = ["user", "site"]
    list_filter = ["site"]
    search_fields = ["user__username"]
    autocomplete_fields = ["user"]
