from django.urls import path

from scheduling.views import (
    FireAlarmAllClearView,
    FireAlarmView,
    LiftPriorityEndView,
    LiftPriorityView,
    ResourceListView,
    ResourceOutOfServiceView,
    ResourceReturnToServiceView,
    RobotMaintenanceView,
    RobotReturnToServiceView,
    TaskCancelView,
    TaskViewSet,
)

urlpatterns = [
    path("tasks/", TaskViewSet.as_view({"get": "list", "post": "create"}), name="task-list"),
    path("tasks/<str:code>", TaskViewSet.as_view({"get": "retrieve"}), name="task-detail"),
    path("tasks/<str:code>/cancel", TaskCancelView.as_view(), name="task-cancel"),
    path("sites/<str:site>/resources/", ResourceListView.as_view(), name="resource-list"),
    path(
        "sites/<str:site>/resources/<str:code>/out-of-service",
        ResourceOutOfServiceView.as_view(),
        name="resource-out-of-service",
    ),
    path(
        "sites/<str:site>/resources/<str:code>/return-to-service",
        ResourceReturnToServiceView.as_view(),
        name="resource-return-to-service",
    ),
    path(
        "robots/<str:robot>/maintenance", RobotMaintenanceView.as_view(), name="robot-maintenance"
    ),
    path(
        "robots/<str:robot>/return-to-service",
        RobotReturnToServiceView.as_view(),
        name="robot-return-to-service",
    ),
    path(
        "sites/<str:site>/resources/<str:code>/priority",
        LiftPriorityView.as_view(),
        name="lift-priority",
    ),
    path(
        "sites/<str:site>/resources/<str:code>/priority/end",
        LiftPriorityEndView.as_view(),
        name="lift-priority-end",
    ),
    path("sites/<str:site>/fire-alarm", FireAlarmView.as_view(), name="fire-alarm"),
    path(
        "sites/<str:site>/fire-alarm/all-clear",
        FireAlarmAllClearView.as_view(),
        name="fire-alarm-all-clear",
    ),
]
