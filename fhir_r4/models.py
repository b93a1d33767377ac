"""What a hospital system sent with a delivery it ordered over FHIR, kept beside the task.

`focus` (the order) and `beneficiary` (Task.for, the patient) are patient-linked: they are
kept as references and identifiers only (their `display`, a patient's name, is dropped), read
only through fhir_r4.selectors, and never written to logs.
"""

from django.db import models
from django.db.models import Q
from django.utils import timezone


class Order(models.Model):
    """The FHIR Task a delivery was created from: its business identifier (unique per site, so
    an interface engine's retry finds it again), the order and patient it is for, who asked."""

    task = models.OneToOneField(
        "scheduling.Task", on_delete=models.CASCADE, related_name="fhir_order"
    )
    site = models.ForeignKey("robots.Site", on_delete=models.CASCADE, related_name="+")
    identifier_system = models.CharField(max_length=500, blank=True)
    identifier_value = models.CharField(max_length=200, blank=True)
    intent = models.CharField(max_length=20)
    priority = models.CharField(max_length=8, help_text="as ordered: routine, urgent, asap, stat")
    focus = models.JSONField(null=True, blank=True, help_text="Task.focus: the order")
    beneficiary = models.JSONField(null=True, blank=True, help_text="Task.for: the patient")
    requester = models.JSONField(null=True, blank=True, help_text="Task.requester")
    cancel_reason = models.CharField(max_length=200, blank=True)
    created_at = models.DateTimeField(default=timezone.now)

    class Meta:
        constraints = [
            models.UniqueConstraint(
                fields=["site", "identifier_system", "identifier_value"],
                condition=~Q(identifier_value=""),
                name="fhir_order_identifier_once",
            ),
        ]

    def __str__(self):
        return f"FHIR order of task {self.task_id}"
