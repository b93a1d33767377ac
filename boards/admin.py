from django.contrib import admin

from boards.models import BoardMessage, RobotEvent, RobotRequest
from boards.services import board_withdraw


class ReadOnlyAdmin(admin.ModelAdmin):
    """Records of what robots and the server said: evidence, so never edited by hand."""

    def has_add_permission(self, request):
        return False

    def has_change_permission(self, request, obj=None):
        return False

    def has_delete_permission(self, request, obj=None):
        return False


@admin.register(BoardMessage)
class BoardMessageAdmin(ReadOnlyAdmin):
    list_display = ["public_id", "robot", "type", "posted_at", "acked_at", "withdrawn_at"]
    list_filter = ["type", "robot", ("acked_at", admin.EmptyFieldListFilter)]
    search_fields = ["robot__code", "key"]
    list_select_related = ["robot"]
    date_hierarchy = "posted_at"
    actions = ["withdraw"]

    @admin.display(description="id", ordering="id")
    def public_id(self, message):
        return message.public_id

    @admin.action(description="Withdraw from the board (the robot will not receive it)")
    def withdraw(self, request, queryset):
        count = board_withdraw(messages=queryset, reason=f"withdrawn by {request.user}")
        self.message_user(request, f"Withdrew {count} pending message(s).")


@admin.register(RobotEvent)
class RobotEventAdmin(ReadOnlyAdmin):
    list_display = ["event_id", "robot", "type", "task", "stop", "resource", "at", "received_at"]
    list_filter = ["type", "robot"]
    search_fields = ["event_id", "task", "resource", "robot__code"]
    list_select_related = ["robot"]
    date_hierarchy = "received_at"


@admin.register(RobotRequest)
class RobotRequestAdmin(ReadOnlyAdmin):
    list_display = ["request_id", "robot", "type", "resource", "to_floor", "received_at"]
    list_filter = ["type", "resource", "robot"]
    search_fields = ["request_id", "robot__code"]
    list_select_related = ["robot"]
