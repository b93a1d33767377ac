"""Websocket routes. Robots authenticate with their token and send no Origin header, so their
route is outside the origin check that protects the pages' sockets. The pages' route checks
the Origin against ALLOWED_HOSTS (any port: pages come from gunicorn, the socket is daphne's)
and reads the Django session from the cookie."""

from channels.auth import AuthMiddlewareStack
from channels.routing import URLRouter
from channels.security.websocket import AllowedHostsOriginValidator
from django.urls import path

from boards.consumers import RobotPushConsumer
from ui.live.consumers import SiteConsumer

robot_websocket_urlpatterns = [
    path("ws/robots/<str:robot>", RobotPushConsumer.as_asgi()),
]

page_websocket_urlpatterns = [
    path(
        "ws/sites/<str:site>",
        AllowedHostsOriginValidator(AuthMiddlewareStack(SiteConsumer.as_asgi())),
    ),
]

websocket_application = URLRouter([*robot_websocket_urlpatterns, *page_websocket_urlpatterns])
