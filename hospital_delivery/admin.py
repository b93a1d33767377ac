from django.contrib import admin

from hospital_delivery.models import ApiToken


@admin.register(ApiToken)
class ApiTokenAdmin(admin.ModelAdmin):
    list_display = ["user", "created_at"]
    search_fields = ["user__username"]
    readonly_fields = ["user", "created_at"]

    def has_add_permission(self, request):
        return False  # issued with `manage.py user_token`, which shows the token once
