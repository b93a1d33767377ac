from django.urls import path

from scheduling import pages

urlpatterns = [
    path("", pages.deliveries, name="deliveries"),
    path("deliveries/<str:code>/", pages.task_history, name="task-history"),
    path("deliveries/<str:code>/cancel", pages.task_cancel_post, name="task-cancel-page"),
]
