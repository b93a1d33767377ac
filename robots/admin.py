"""Admin for sites and robots.

The map (floors, waypoints, edges, resources) comes from site files (`manage.py load_site`),
which validate the whole map; the admin shows it and lets operators fix names and site
settings, never the geometry, which would bypass that validation and the routing caches.
"""

from django import forms
from django.contrib import admin, messages
from django.db.models import F

from robots.alerts import alert_acknowledge
from robots.models import (
    Alert,
    Edge,
    Floor,
    PresenceChange,
    Resource,
    ResourceWaypoint,
    Robot,
    Site,
    SiteMembership,
    Waypoint,
)
from robots.services import membership_badge_set, robot_token_issue


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


@admin.register(Resource)
class ResourceAdmin(MapAdmin):
    list_display = ["code", "name", "kind", "capacity", "site"]
    list_filter = ["site", "kind"]
    search_fields = ["code", "name"]
    inlines = [ResourceWaypointInline]


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
        "protocol",
        "presence",
        "status",
        "floor",
        "waypoint",
        "battery",
        "load",
        "capacity",
        "last_seen_at",
    ]
    list_filter = ["site", "protocol", "presence", "status"]
    search_fields = ["code", "name", "serial_number"]
    list_select_related = ["site", "floor", "waypoint"]
    actions = ["issue_token"]
    inlines = [PresenceChangeInline]
    reported = [*Robot.STATE_FIELDS, "boot_id", "seq"]
    presence_fields = [*Robot.PRESENCE_FIELDS, "paused_by_operator"]
    fieldsets = [
        (None, {"fields": ["code", "name", "site", "dock", "capacity", "token_issued_at"]}),
        # From the site file, like the dock: a VDA 5050 vehicle's identity on its MQTT topics.
        ("Protocol", {"fields": ["protocol", "manufacturer", "serial_number"]}),
        ("Presence", {"fields": presence_fields}),
        ("Last reported state", {"fields": reported}),
    ]
    readonly_fields = [
        "token_issued_at",
        "protocol",
        "manufacturer",
        "serial_number",
        *presence_fields,
        *reported,
    ]

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


class SiteMembershipForm(forms.ModelForm):
    """The badge is typed (or scanned) here and only its salted hash is kept."""

    badge = forms.CharField(
        required=False,
        max_length=128,
        strip=True,
        widget=forms.PasswordInput(render_value=False),
        help_text="scan or type the badge id to set it (only its salted hash is kept); "
        "left empty, the current one stays",
    )
    forget_badge = forms.BooleanField(required=False, help_text="the user has no badge any more")

    class Meta:
        model = SiteMembership
        fields = ["user", "site", "unit"]


@admin.register(SiteMembership)
class SiteMembershipAdmin(admin.ModelAdmin):
    """Who works at which site (staff users and superusers see every site without one), in
    which unit, and their badge, for secure deliveries to that unit."""

    form = SiteMembershipForm
    list_display = ["user", "site", "unit", "has_badge"]
    list_filter = ["site"]
    search_fields = ["user__username"]
    autocomplete_fields = ["user"]

    @admin.display(boolean=True, description="badge")
    def has_badge(self, membership) -> bool:
        return bool(membership.badge_hash)

    def save_model(self, request, obj, form, change):
        super().save_model(request, obj, form, change)
        badge = form.cleaned_data.get("badge")
        if badge or form.cleaned_data.get("forget_badge"):
            membership_badge_set(membership=obj, badge=badge or "")
