from django.urls import path

from audit import views

urlpatterns = [
    path("audit/", views.entries_page, name="audit-entries"),
    path("audit/entries.csv", views.entries_export, {"extension": "csv"}, name="audit-csv"),
    path("audit/entries.json", views.entries_export, {"extension": "json"}, name="audit-json"),
]
