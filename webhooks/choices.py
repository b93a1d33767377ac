from django.db import models


class DeliveryState(models.TextChoices):
    PENDING = "pending", "Pending (sent when due, retried until answered)"
    DELIVERED = "delivered", "Delivered (answered 2xx)"
    FAILED = "failed", "Given up after every attempt failed"


# The only event type so far: a delivery task changed status (its creation included).
TASK_STATUS_CHANGED = "task.status_changed"


class PayloadFormat(models.TextChoices):
    """What a subscription receives of a status change."""

    NATIVE = "native", "Our event (task.status_changed)"
    FHIR = "fhir", "The FHIR R4 Task as it is now"
