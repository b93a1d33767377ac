"""Admin for delivery tasks: a read-only record; changes go through the API's services."""

from django.contrib import admin

from scheduling.models import (
    OperatorAction,
    RecurringRequest,
    RobotPlan,
    Task,
    TaskStop,
    TaskTransition,
)


class ReadOnlyInline(admin.TabularInline):
    extra = 0
    can_delete = False

    def has_add_permission(self, request, obj=None):
        return False

    def has_change_permission(self, request, obj=None):
        return False


class TaskStopInline(ReadOnlyInline):
    model = TaskStop
    fields = ["index", "action", "waypoint", "load_change", "done_at", "skipped_at"]


class TaskTransitionInline(ReadOnlyInline):
    model = TaskTransition
    fields = ["at", "old", "new", "cause", "robot", "event", "user", "note"]


@admin.register(Task)
class TaskAdmin(admin.ModelAdmin):
    list_display = ["code", "status", "priority", "contents", "robot", "requested_time", "eta"]
    list_filter = ["status", "priority", "site"]
    search_fields = ["contents", "sender", "receiver"]
    list_select_related = ["robot"]
    inlines = [TaskStopInline, TaskTransitionInline]

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False


@admin.register(RecurringRequest)
class RecurringRequestAdmin(admin.ModelAdmin):
    list_display = ["id", "contents", "repeat", "active", "starts_at"]
    list_filter = ["active"]
    fields = ["active"]


@admin.register(RobotPlan)
class RobotPlanAdmin(admin.ModelAdmin):
    list_display = ["robot", "version", "posted_at"]

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False


@admin.register(OperatorAction)
class OperatorActionAdmin(admin.ModelAdmin):
    """Who told a robot, lift or door what, and when: a record, never edited."""

    list_display = ["at", "action", "robot", "resource", "by", "note"]
    list_filter = ["action"]
    list_select_related = ["robot", "resource", "by"]

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False

    def has_delete_permission(self, request, obj=None):
        return False
