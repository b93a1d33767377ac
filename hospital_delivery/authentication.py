from rest_framework import authentication, exceptions

from core.statements import Statement
from core.tokens import bearer_token, token_hash
from hospital_delivery.models import ApiToken

# Every API call of a hospital system looks its token up: compiled once (core.statements).
_TOKEN = Statement(
    lambda hashed: ApiToken.objects.filter(token_hash=hashed).select_related("user"), hashed=str
)


class ApiTokenAuthentication(authentication.BaseAuthentication):
    """`Authorization: Bearer <token>` for users, tokens issued by `manage.py user_token`."""

    def authenticate(self, request):
        token = bearer_token(request.headers.get("Authorization"))
        if token is None:
            return None
        api_token = _TOKEN.first(hashed=token_hash(token))
        if api_token is None or not api_token.user.is_active:
            raise exceptions.AuthenticationFailed("invalid or revoked token")
        return api_token.user, api_token

    def authenticate_header(self, request):
        return "Bearer"
