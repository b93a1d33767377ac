"""Subscriptions of other hospital systems, and the deliveries of events to them.

A delivery row is written in the transaction that changes the task (webhooks/receivers.py),
so an event is never lost between the change and the send; it is then sent until answered
2xx, at least once. Its `event_id` is the same for every attempt and every subscription, so
a receiver drops the repeats it has seen.
"""

import secrets

from django.core.exceptions import ValidationError
from django.db import models
from django.db.models import Q
from django.utils import timezone

from scheduling.choices import TaskStatus
from webhooks.choices import AttemptFailure, DeliveryState, PayloadFormat
from webhooks.targets import TargetRefused, target_check


def secret_new() -> str:
    return secrets.token_urlsafe(32)


class Subscription(models.Model):
    """A URL of another system that hears of a site's task status changes, signed with its
    secret (HMAC-SHA256; docs/integrators/webhooks.md)."""

    site = models.ForeignKey("robots.Site", on_delete=models.CASCADE, related_name="+")
    name = models.CharField(max_length=200, help_text="who listens, e.g. Laboratory system")
    url = models.URLField(max_length=500, help_text="http(s) URL the events are POSTed to")
    secret = models.CharField(
        max_length=200, default=secret_new, help_text="key of the HMAC-SHA256 signature"
    )
    statuses = models.JSONField(
        default=list,
        blank=True,
        help_text='task statuses to send, e.g. ["picked_up", "delivered", "failed"]; '
        "empty: every status change",
    )
    payload_format = models.CharField(
        max_length=8,
        choices=PayloadFormat,
        default=PayloadFormat.NATIVE,
        help_text="our event, or the FHIR Task as it is now (docs/integrators/fhir.md)",
    )
    active = models.BooleanField(default=True)
    created_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["site", "name", "id"]
        indexes = [models.Index(fields=["site"], condition=Q(active=True), name="webhook_active")]

    def __str__(self):
        return f"{self.name} ({self.url})"

    def clean(self):
        if self.url:
            try:
                target_check(self.url)
            except TargetRefused as refused:
                raise ValidationError({"url": [refused.reason.label]}) from None
        statuses = self.statuses
        if not isinstance(statuses, list) or not all(isinstance(s, str) for s in statuses):
            raise ValidationError({"statuses": ["a list of task statuses"]})
        unknown = sorted(set(statuses) - set(TaskStatus.values))
        if unknown:
            known = ", ".join(TaskStatus.values)
            raise ValidationError({"statuses": [f"unknown {', '.join(unknown)} (use {known})"]})

    def wants(self, status: str) -> bool:
        return not self.statuses or status in self.statuses


class WebhookDeliveryQuerySet(models.QuerySet):
    def due(self, now):
        return self.filter(state=DeliveryState.PENDING, next_attempt_at__lte=now)


class WebhookDelivery(models.Model):
    """One event for one subscription, from its creation until answered 2xx or given up."""

    subscription = models.ForeignKey(
        Subscription, on_delete=models.CASCADE, related_name="deliveries"
    )
    event_id = models.CharField(max_length=64, help_text="the same for every attempt")
    event = models.CharField(max_length=64)
    payload = models.JSONField()
    state = models.CharField(max_length=12, choices=DeliveryState, default=DeliveryState.PENDING)
    created_at = models.DateTimeField(default=timezone.now)
    next_attempt_at = models.DateTimeField(
        help_text="sent when this passes; pushed on while an attempt runs (its claim)"
    )
    attempts = models.PositiveSmallIntegerField(default=0)
    last_attempt_at = models.DateTimeField(null=True, blank=True)
    last_status_code = models.PositiveSmallIntegerField(null=True, blank=True)
    # Only the status and a fixed reason: never the answer's body or an error's text.
    last_error = models.CharField(max_length=300, blank=True, choices=AttemptFailure)
    delivered_at = models.DateTimeField(null=True, blank=True)

    objects = WebhookDeliveryQuerySet.as_manager()

    class Meta:
        verbose_name_plural = "webhook deliveries"
        ordering = ["-id"]
        constraints = [
            models.UniqueConstraint(
                fields=["subscription", "event_id"], name="webhook_delivery_once"
            ),
        ]
        indexes = [
            models.Index(
                fields=["next_attempt_at"],
                condition=Q(state=DeliveryState.PENDING),
                name="webhook_delivery_due",
            ),
        ]

    def __str__(self):
        return f"{self.event_id} to {self.subscription_id} ({self.state})"
