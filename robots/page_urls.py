from django.urls import path

from robots import pages

urlpatterns = [
    path("fleet/", pages.fleet, name="fleet"),
    path("robots/<str:code>/", pages.robot_page, name="robot-page"),
    path("robots/<str:code>/action", pages.robot_action_post, name="robot-action"),
    path("alerts/<int:pk>/acknowledge", pages.alert_acknowledge_post, name="alert-acknowledge"),
]
