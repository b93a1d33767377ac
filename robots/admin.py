"""Admin for sites and robots.

The map (floors, waypoints, edges, resources) comes from site files (`manage.py load_site`),
which validate the whole map; the admin shows it and lets operators fix names and site
settings, never the geometry, which would bypass that validation and the routing caches.
"""

from django.contrib import admin, messages
from django.db.models import F

from robots.alerts import alert_acknowledge
from robots.leases import lease_revoke
from robots.models import (
    Alert,
    Edge,
    Floor,
    Lease,
    PresenceChange,
    Resource,
    ResourceWaypoint,
    Robot,
    Site,
    Waypoint,
)
from robots.services import robot_token_issue


class ReadOnlyInline(admin.TabularInline):
    extra = 0
    can_delete = False
    show_change_link = True

    def has_add_permission(self, request, obj=None):
        return False

    def has_change_permission(self, request, obj=None):
        return False


class FloorInline(ReadOnlyInline):
    model = Floor
    fields = ["code", "level", "name"]


@admin.register(Site)
class SiteAdmin(admin.ModelAdmin):
    list_display = ["code", "name", "robot_speed", "heartbeat_interval", "map_version", "loaded_at"]
    search_fields = ["code", "name"]
    readonly_fields = ["code", "map_version", "loaded_at"]
    inlines = [FloorInline]
    fieldsets = [
        (None, {"fields": ["code", "name", "map_version", "loaded_at"]}),
        (
            "Robots and timing",
            {
                "fields": [
                    "robot_speed",
                    "heartbeat_interval",
                    "ack_timeout",
                    "offline_timeout",
                    "battery_threshold",
                ]
            },
        ),
        ("Resource leases", {"fields": ["grant_timeout", "lease_hard_limit"]}),
    ]

    def has_add_permission(self, request):
        return False  # sites come from site files

    def save_model(self, request, obj, form, change):
        # robot_speed changes travel times: make every process rebuild its routing cache.
        obj.save()
        if "robot_speed" in form.changed_data:
            Site.objects.filter(pk=obj.pk).update(map_version=F("map_version") + 1)


class MapAdmin(admin.ModelAdmin):
    """Map rows: names may be edited, structure may not."""

    editable_fields: list[str] = ["name"]

    def get_readonly_fields(self, request, obj=None):
        return [f.name for f in self.model._meta.fields if f.name not in self.editable_fields]

    def has_add_permission(self, request):
        return False

    def has_delete_permission(self, request, obj=None):
        return False


@admin.register(Floor)
class FloorAdmin(MapAdmin):
    list_display = ["code", "level", "name", "site"]
    list_filter = ["site"]
    search_fields = ["code", "name"]


@admin.register(Waypoint)
class WaypointAdmin(MapAdmin):
    list_display = ["code", "name", "kind", "floor", "x", "y", "site"]
    list_filter = ["site", "kind", "floor"]
    search_fields = ["code", "name"]
    list_select_related = ["floor", "site"]


@admin.register(Edge)
class EdgeAdmin(MapAdmin):
    editable_fields = []
    list_display = ["source", "target", "length", "oneway", "guarded_by", "site"]
    list_filter = ["site", "oneway", "guarded_by"]
    search_fields = ["source__code", "target__code"]
    list_select_related = ["source", "target", "guarded_by", "site"]


class ResourceWaypointInline(ReadOnlyInline):
    model = ResourceWaypoint
    fields = ["waypoint"]
    show_change_link = False
    verbose_name = "waiting waypoint"


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


@admin.register(Resource)
class ResourceAdmin(MapAdmin):
    list_display = ["code", "name", "kind", "capacity", "site"]
    list_filter = ["site", "kind"]
    search_fields = ["code", "name"]
    inlines = [ResourceWaypointInline, LiveLeaseInline]


class PresenceChangeInline(ReadOnlyInline):
    model = PresenceChange
    fields = ["at", "old", "new", "cause"]
    show_change_link = False
    max_num = 20
    verbose_name_plural = "recent presence changes"


@admin.register(Robot)
class RobotAdmin(admin.ModelAdmin):
    list_display = [
        "code",
        "site",
        "presence",
        "status",
        "floor",
        "waypoint",
        "battery",
        "load",
        "capacity",
        "last_seen_at",
    ]
    list_filter = ["site", "presence", "status"]
    search_fields = ["code", "name"]
    list_select_related = ["site", "floor", "waypoint"]
    actions = ["issue_token"]
    inlines = [PresenceChangeInline]
    reported = [*Robot.STATE_FIELDS, "boot_id", "seq"]
    presence_fields = [*Robot.PRESENCE_FIELDS, "paused_by_operator"]
    fieldsets = [
        (None, {"fields": ["code", "name", "site", "dock", "capacity", "token_issued_at"]}),
        ("Presence", {"fields": presence_fields}),
        ("Last reported state", {"fields": reported}),
    ]
    readonly_fields = ["token_issued_at", *presence_fields, *reported]

    def get_readonly_fields(self, request, obj=None):
        # A robot's site and code are fixed once it exists: its history and tokens refer to them.
        fixed = ["code", "site"] if obj is not None else []
        return [*fixed, *self.readonly_fields]

    @admin.action(description="Issue a new token (revokes the old one)")
    def issue_token(self, request, queryset):
        for robot in queryset:
            token = robot_token_issue(robot=robot)
            self.message_user(
                request,
                f"New token for {robot.code} (shown once, copy it now): {token}",
                messages.WARNING,
            )


@admin.register(PresenceChange)
class PresenceChangeAdmin(admin.ModelAdmin):
    list_display = ["robot", "at", "old", "new", "cause"]
    list_filter = ["new", "cause", "robot"]
    date_hierarchy = "at"

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False


@admin.register(Alert)
class AlertAdmin(admin.ModelAdmin):
    list_display = ["raised_at", "kind", "message", "robot", "resource", "task", "acknowledged_at"]
    list_filter = ["site", "kind", ("acknowledged_at", admin.EmptyFieldListFilter)]
    search_fields = ["message", "task", "robot__code", "key"]
    list_select_related = ["robot", "resource"]
    readonly_fields = [f.name for f in Alert._meta.fields]
    actions = ["acknowledge"]

    def has_add_permission(self, request):
        return False

    @admin.action(description="Acknowledge")
    def acknowledge(self, request, queryset):
        count = sum(alert_acknowledge(alert=alert, user=request.user) for alert in queryset)
        self.message_user(request, f"Acknowledged {count} alert(s).")


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
        return request.user.has_perm("robots.change_lease")

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
