from django.db import models


class DeliveryState(models.TextChoices):
    PENDING = "pending", "Pending (sent when due, retried until answered)"
    DELIVERED = "delivered", "Delivered (answered 2xx)"
    FAILED = "failed", "Given up after every attempt failed"


# The only event type so far: a delivery task changed status (its creation included).
TASK_STATUS_CHANGED = "task.status_changed"
