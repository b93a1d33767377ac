"""The audit trail in the admin: read only, even for superusers (django-auditlog's own admin
lets a cascade delete entries; this one replaces it)."""

from django.contrib import admin

from audit.models import AuditEntry

admin.site.unregister(AuditEntry)


@admin.register(AuditEntry)
class AuditEntryAdmin(admin.ModelAdmin):
    date_hierarchy = "timestamp"
    list_display = ["id", "timestamp", "kind", "action", "actor_name", "remote_addr", "site_id"]
    list_display_links = ["id"]
    list_filter = ["kind", "action"]
    search_fields = ["actor_name", "object_repr", "remote_addr"]
    list_select_related = ["content_type"]
    readonly_fields = [field.name for field in AuditEntry._meta.fields]

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False

    def has_delete_permission(self, request, obj=None):
        return False
