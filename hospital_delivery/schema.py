"""OpenAPI descriptions of our authentication schemes (drf-spectacular extensions)."""

from drf_spectacular.extensions import OpenApiAuthenticationExtension


class ApiTokenScheme(OpenApiAuthenticationExtension):
    target_class = "hospital_delivery.authentication.ApiTokenAuthentication"
    name = "userToken"

    def get_security_definition(self, auto_schema):
        return {
            "type": "http",
            "scheme": "bearer",
            "description": "A staff user's token from `manage.py user_token USERNAME`.",
        }


class RobotTokenScheme(OpenApiAuthenticationExtension):
    target_class = "robots.authentication.RobotTokenAuthentication"
    match_subclasses = True  # the heartbeat's RobotTokenLockingAuthentication too
    name = "robotToken"

    def get_security_definition(self, auto_schema):
        return {
            "type": "http",
            "scheme": "bearer",
            "description": "The robot's own token from `manage.py robot_token CODE`.",
        }
