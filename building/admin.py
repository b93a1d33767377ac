"""The building's devices in the admin: view-only (the leases and the devices' reports drive
them; operators use the fleet page's panels)."""

from django.contrib import admin

from building.models import Device


@admin.register(Device)
class DeviceAdmin(admin.ModelAdmin):
    list_display = [
        "resource",
        "adapter",
        "session",
        "requested_floor",
        "current_floor",
        "motion",
        "door",
        "fault",
        "reported_at",
    ]
    list_filter = ["adapter", "resource__site"]
    list_select_related = ["resource", "requested_floor", "current_floor"]

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False

    def has_delete_permission(self, request, obj=None):
        return False
