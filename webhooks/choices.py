from django.db import models


class DeliveryState(models.TextChoices):
    PENDING = "pending", "Pending (sent when due, retried until answered)"
    DELIVERED = "delivered", "Delivered (answered 2xx)"
    FAILED = "failed", "Given up after every attempt failed"


# The only event type so far: a delivery task changed status (its creation included).
TASK_STATUS_CHANGED = "task.status_changed"


class AttemptFailure(models.TextChoices):
    """Why an attempt failed, in fixed words: the page never shows what a receiver answered or
    a connection error's text (they would tell an operator about hosts and ports inside)."""

    NOT_HTTP = "not_http", "The URL is not an http(s) URL with a host name"
    UNRESOLVED = "unresolved", "The host name does not resolve"
    ADDRESS_REFUSED = (
        "address_refused",
        "The host is inside the hospital's network or the server (WEBHOOK_ALLOWED_NETWORKS)",
    )
    UNREACHABLE = "unreachable", "No connection could be made"
    TIMEOUT = "timeout", "No answer in time"
    TLS = "tls", "The TLS handshake or the certificate check failed"
    BAD_ANSWER = "bad_answer", "The answer was not valid HTTP"
    REDIRECT = "redirect", "Answered with a redirect, which is never followed"
    NOT_2XX = "not_2xx", "Answered with a status other than 2xx"


class PayloadFormat(models.TextChoices):
    """What a subscription receives of a status change."""

    NATIVE = "native", "Our event (task.status_changed)"
    FHIR = "fhir", "The FHIR R4 Task as it is now"
