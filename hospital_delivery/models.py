from django.conf import settings
from django.db import models, transaction
from django.utils import timezone

from core.tokens import token_hash, token_new


class ApiTokenQuerySet(models.QuerySet):
    def for_token(self, token: str):
        return self.filter(token_hash=token_hash(token)).select_related("user")


class ApiToken(models.Model):
    """A staff user's token for hospital systems that call the API (one per user)."""

    user = models.OneToOneField(
        settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="api_token"
    )
    token_hash = models.CharField(max_length=64, unique=True, editable=False)
    created_at = models.DateTimeField(default=timezone.now, editable=False)

    objects = ApiTokenQuerySet.as_manager()

    class Meta:
        verbose_name = "API token"

    def __str__(self):
        return f"API token of {self.user}"

    @classmethod
    @transaction.atomic
    def issue(cls, user) -> str:
        """Issue a new token for user, revoking the previous one; returns the token (shown once)."""
        token, hashed = token_new()
        cls.objects.update_or_create(
            user=user, defaults={"token_hash": hashed, "created_at": timezone.now()}
        )
        return token


class SignInThrottle(models.Model):
    """Failed sign-ins from one client address within a window (hospital_delivery/signin.py):
    past the limit, that address's sign-ins are refused before any password is hashed."""

    address = models.GenericIPAddressField(unique=True)
    window_started_at = models.DateTimeField(db_index=True)
    failures = models.PositiveIntegerField(default=0)

    def __str__(self):
        return f"{self.address}: {self.failures} failed sign-ins since {self.window_started_at}"
