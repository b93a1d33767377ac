from django.urls import path

from scheduling.views import TaskCancelView, TaskViewSet

urlpatterns = [
    path("tasks/", TaskViewSet.as_view({"get": "list", "post": "create"}), name="task-list"),
    path("tasks/<str:code>", TaskViewSet.as_view({"get": "retrieve"}), name="task-detail"),
    path("tasks/<str:code>/cancel", TaskCancelView.as_view(), name="task-cancel"),
]
