from django.urls import path

from boards.views import HeartbeatView

urlpatterns = [
    path("robots/<str:robot>/heartbeat", HeartbeatView.as_view(), name="robot-heartbeat"),
]
