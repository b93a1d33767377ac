from django.contrib.auth.models import AnonymousUser
from rest_framework import authentication, exceptions, permissions

from core.tokens import bearer_token
from robots.services import robot_authenticate


class RobotTokenAuthentication(authentication.BaseAuthentication):
    """`Authorization: Bearer <robot token>`; the robot becomes request.auth."""

    lock_robot = False

    def authenticate(self, request):
        token = bearer_token(request.headers.get("Authorization"))
        if token is None:
            return None
        robot = self.robot_find(token)
        if robot is None:
            raise exceptions.AuthenticationFailed("invalid or revoked robot token")
        return AnonymousUser(), robot

    def robot_find(self, token: str):
        return robot_authenticate(token=token, lock=self.lock_robot)

    def authenticate_header(self, request):
        return "Bearer"


class RobotTokenLockingAuthentication(RobotTokenAuthentication):
    """The same, and the robot's row is locked (robots.services.robot_lock) for the rest of the
    transaction the view runs in: a heartbeat's lock, taken by the query that authenticates."""

    lock_robot = True


class IsRobotInUrl(permissions.BasePermission):
    """Only the robot named in the URL may use it: 401 without a token, 403 with another's."""

    message = "this token belongs to another robot"

    def has_permission(self, request, view):
        if request.auth is None:
            raise exceptions.NotAuthenticated("a robot token is required")
        return request.auth.code == view.kwargs["robot"]
