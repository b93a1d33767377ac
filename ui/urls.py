from django.urls import path

from ui import deliveries, fleet
from ui.live import state

urlpatterns = [
    path("", deliveries.deliveries, name="deliveries"),
    path("deliveries/<str:code>/", deliveries.task_history, name="task-history"),
    path("deliveries/<str:code>/cancel", deliveries.task_cancel_post, name="task-cancel-page"),
    path("fleet/", fleet.fleet, name="fleet"),
    path("robots/<str:code>/", fleet.robot_page, name="robot-page"),
    path("robots/<str:code>/action", fleet.robot_action_post, name="robot-action"),
    path("alerts/<int:pk>/acknowledge", fleet.alert_acknowledge_post, name="alert-acknowledge"),
    path("live/<str:site>/state.json", state.state, name="live-state"),
]
