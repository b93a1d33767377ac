from django.contrib import admin

from webhooks.models import Subscription, WebhookDelivery


@admin.register(Subscription)
class SubscriptionAdmin(admin.ModelAdmin):
    list_display = ["name", "site", "url", "payload_format", "active", "created_at"]
    list_filter = ["site", "active", "payload_format"]


@admin.register(WebhookDelivery)
class WebhookDeliveryAdmin(admin.ModelAdmin):
    list_display = ["event_id", "subscription", "state", "attempts", "last_status_code"]
    list_filter = ["state", "subscription"]
    readonly_fields = [field.name for field in WebhookDelivery._meta.fields]

    def has_add_permission(self, request):
        return False
