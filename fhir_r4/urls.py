from django.urls import path, re_path

from fhir_r4.views import (
    DeviceInstanceView,
    DeviceTypeView,
    LocationInstanceView,
    LocationTypeView,
    MetadataView,
    TaskInstanceView,
    TaskTypeView,
    TaskVersionView,
)

# FHIR ids: letters, digits, "-" and "." (up to 64).
ID = r"(?P<{}>[A-Za-z0-9\-.]{{1,64}})"

urlpatterns = [
    path("metadata", MetadataView.as_view(), name="fhir-metadata"),
    path("Task", TaskTypeView.as_view(), name="fhir-task-type"),
    re_path(rf"^Task/{ID.format('code')}$", TaskInstanceView.as_view(), name="fhir-task"),
    re_path(
        rf"^Task/{ID.format('code')}/_history/{ID.format('version')}$",
        TaskVersionView.as_view(),
        name="fhir-task-version",
    ),
    path("Location", LocationTypeView.as_view(), name="fhir-location-type"),
    re_path(
        rf"^Location/{ID.format('ident')}$", LocationInstanceView.as_view(), name="fhir-location"
    ),
    path("Device", DeviceTypeView.as_view(), name="fhir-device-type"),
    re_path(rf"^Device/{ID.format('ident')}$", DeviceInstanceView.as_view(), name="fhir-device"),
]
