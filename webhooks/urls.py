from django.urls import path

from webhooks import views

urlpatterns = [
    path("webhooks/", views.webhooks_page, name="webhooks"),
]
