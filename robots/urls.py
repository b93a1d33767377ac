from django.urls import path

from robots.views import RobotViewSet

urlpatterns = [
    path("robots/", RobotViewSet.as_view({"get": "list"}), name="robot-list"),
    path("robots/<str:robot>", RobotViewSet.as_view({"get": "retrieve"}), name="robot-detail"),
]
