from django.urls import path

from reports import views

urlpatterns = [
    path("reports/", views.reports_page, name="reports"),
    path("reports/<str:table>.csv", views.report_csv, name="report-csv"),
    path("metrics", views.metrics, name="metrics"),
]
