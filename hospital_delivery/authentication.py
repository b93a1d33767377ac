from rest_framework import authentication, exceptions

from core.tokens import bearer_token, token_hash
from hospital_delivery.models import ApiToken


class ApiTokenAuthentication(authentication.BaseAuthentication):
    """`Authorization: Bearer <token>` for users, tokens issued by `manage.py user_token`."""

    def authenticate(self, request):
        token = bearer_token(request.headers.get("Authorization"))
        if token is None:
            return None
        hashed = token_hash(token)
        api_token = ApiToken.objects.filter(token_hash=hashed).select_related("user").first()
        if api_token is None or not api_token.user.is_active:
            raise exceptions.AuthenticationFailed("invalid or revoked token")
        return api_token.user, api_token

    def authenticate_header(self, request):
        return "Bearer"
