"""Websocket routes. Robots authenticate with their token and send no Origin header, so their
route is outside the origin check that protects the pages' sockets."""

from channels.routing import URLRouter
from django.urls import path

from boards.consumers import RobotPushConsumer

robot_websocket_urlpatterns = [
    path("ws/robots/<str:robot>", RobotPushConsumer.as_asgi()),
]

websocket_application = URLRouter(robot_websocket_urlpatterns)
