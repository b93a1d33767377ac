"""Admin of the resource controller: leases are view-only, plus force-release; each resource's
page in the map's admin also lists who holds and who waits for it."""

from django.contrib import admin, messages

from resources.leases import lease_revoke
from resources.models import Lease
from robots.admin import ReadOnlyInline, ResourceAdmin
from robots.models import Resource


class LiveLeaseInline(ReadOnlyInline):
    """Who holds the resource and who waits for it, in the order they will be served."""

    model = Lease
    fields = ["lease", "robot", "state", "position", "to_floor", "requested_at", "expires_at"]
    readonly_fields = fields
    verbose_name_plural = "live leases (holders, then the queue in order)"

    def get_queryset(self, request):
        leases = super().get_queryset(request).live().in_queue_order().with_queue_position()
        return leases.select_related("robot", "to_floor")

    @admin.display(description="lease")
    def lease(self, obj):
        return obj.public_id

    @admin.display(description="queue position")
    def position(self, obj):
        return obj.queue_position


admin.site.unregister(Resource)


@admin.register(Resource)
class ResourceWithLeasesAdmin(ResourceAdmin):
    inlines = [*ResourceAdmin.inlines, LiveLeaseInline]


@admin.register(Lease)
class LeaseAdmin(admin.ModelAdmin):
    """Leases are changed only by the resource controller: view-only, plus force-release."""

    list_display = [
        "lease",
        "resource",
        "robot",
        "state",
        "position",
        "to_floor",
        "requested_at",
        "granted_at",
        "expires_at",
        "entered_at",
        "ended_at",
        "end_cause",
    ]
    list_filter = ["state", "resource__site", "resource"]
    search_fields = ["robot__code", "resource__code", "request_id"]
    list_select_related = ["resource", "robot", "to_floor"]
    readonly_fields = [f.name for f in Lease._meta.fields]
    actions = ["force_release"]

    def get_queryset(self, request):
        return super().get_queryset(request).with_queue_position()

    @admin.display(description="lease", ordering="pk")
    def lease(self, obj):
        return obj.public_id

    @admin.display(description="queue position", ordering="queue_position")
    def position(self, obj):
        return obj.queue_position

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False  # a saved stale form would overwrite the controller's state

    def has_delete_permission(self, request, obj=None):
        return False

    def has_force_release_permission(self, request):
        return request.user.has_perm("resources.change_lease")

    @admin.action(
        description="Force-release (the next in line is granted)", permissions=["force_release"]
    )
    def force_release(self, request, queryset):
        for lease in queryset.select_related("robot", "resource"):
            granted = lease_revoke(lease=lease, by=request.user)
            if granted is None:
                self.message_user(
                    request, f"{lease.public_id} had already ended.", messages.WARNING
                )
                continue
            successors = ", ".join(f"{g.public_id} to {g.robot.code}" for g in granted)
            self.message_user(
                request,
                f"Force-released {lease.public_id} ({lease.robot.code} on {lease.resource.code}); "
                + (f"granted {successors}." if granted else "nobody was waiting."),
            )
