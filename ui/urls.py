from django.urls import path

from ui import custody, deliveries, fleet, maps, recurring, stations, workstation
from ui.live import state

urlpatterns = [
    path("", deliveries.deliveries, name="deliveries"),
    path("deliveries/<str:code>/", deliveries.task_history, name="task-history"),
    path("deliveries/<str:code>/cancel", deliveries.task_cancel_post, name="task-cancel-page"),
    path(
        "deliveries/<str:code>/pin-resend", deliveries.task_pin_resend_post, name="task-pin-resend"
    ),
    path("workstation/", workstation.workstation_page, name="workstation"),
    path("account/pin/", workstation.pin_page, name="account-pin"),
    path("custody.csv", custody.custody_csv, name="custody-csv"),
    path("recurring/", recurring.recurring_list, name="recurring"),
    path("recurring/<int:pk>/stop", recurring.recurring_stop_post, name="recurring-stop"),
    path("stations/", stations.stations, name="stations"),
    path("stations/<str:code>/", stations.station_page, name="station"),
    path("fleet/", fleet.fleet, name="fleet"),
    path("robots/<str:code>/", fleet.robot_page, name="robot-page"),
    path("robots/<str:code>/action", fleet.robot_action_post, name="robot-action"),
    path(
        "robots/<str:code>/maintenance",
        fleet.robot_maintenance_post,
        name="robot-maintenance-page",
    ),
    path("leases/<str:lease_id>/release", fleet.lease_release_post, name="lease-release"),
    path(
        "resources/<str:site>/<str:code>/service",
        fleet.resource_service_post,
        name="resource-service",
    ),
    path(
        "resources/<str:site>/<str:code>/priority",
        fleet.resource_priority_post,
        name="resource-priority",
    ),
    path("resources/<str:site>/<str:code>/doors", fleet.resource_doors_post, name="resource-doors"),
    path("resources/<str:site>/<str:code>/car", fleet.resource_car_post, name="resource-car"),
    path("sites/<str:site>/fire-alarm", fleet.fire_alarm_post, name="fire-alarm-page"),
    path("alerts/<int:pk>/acknowledge", fleet.alert_acknowledge_post, name="alert-acknowledge"),
    path("live/<str:site>/state.json", state.state, name="live-state"),
    path("maps/<str:site>/edit", maps.map_editor, name="map-editor"),
    path("maps/<str:site>/history", maps.map_history, name="map-history"),
    path("maps/<str:site>/versions/<int:number>.yaml", maps.map_export, name="map-export"),
    path(
        "maps/<str:site>/versions/<int:number>/restore",
        maps.map_restore_post,
        name="map-restore-page",
    ),
]
