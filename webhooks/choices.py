from django.db import models
from django.utils.translation import gettext_lazy as _


class DeliveryState(models.TextChoices):
    PENDING = "pending", _("Pending (sent when due, retried until answered)")
    DELIVERED = "delivered", _("Delivered (answered 2xx)")
    FAILED = "failed", _("Given up after every attempt failed")


# The only event type so far: a delivery task changed status (its creation included).
TASK_STATUS_CHANGED = "task.status_changed"


class AttemptFailure(models.TextChoices):
    """Why an attempt failed, in fixed words: the page never shows what a receiver answered or
    a connection error's text (they would tell an operator about hosts and ports inside)."""

    NOT_HTTP = "not_http", _("The URL is not an http(s) URL with a host name")
    UNRESOLVED = "unresolved", _("The host name does not resolve")
    ADDRESS_REFUSED = (
        "address_refused",
        "The host is inside the hospital's network or the server (WEBHOOK_ALLOWED_NETWORKS)",
    )
    UNREACHABLE = "unreachable", _("No connection could be made")
    TIMEOUT = "timeout", _("No answer in time")
    TLS = "tls", _("The TLS handshake or the certificate check failed")
    BAD_ANSWER = "bad_answer", _("The answer was not valid HTTP")
    REDIRECT = "redirect", _("Answered with a redirect, which is never followed")
    NOT_2XX = "not_2xx", _("Answered with a status other than 2xx")


class PayloadFormat(models.TextChoices):
    """What a subscription receives of a status change."""

    NATIVE = "native", _("Our event (task.status_changed)")
    FHIR = "fhir", _("The FHIR R4 Task as it is now")
