from django.urls import path

from maps import views

urlpatterns = [
    path("maps/<str:site>/draft", views.DraftView.as_view(), name="map-draft"),
    path("maps/<str:site>/draft/check", views.DraftCheckView.as_view(), name="map-draft-check"),
    path("maps/<str:site>/draft/upload", views.DraftUploadView.as_view(), name="map-draft-upload"),
    path("maps/<str:site>/draft/reset", views.DraftResetView.as_view(), name="map-draft-reset"),
    path("maps/<str:site>/draft/publish", views.PublishView.as_view(), name="map-publish"),
    path("maps/<str:site>/rollout", views.RolloutView.as_view(), name="map-rollout"),
    path("maps/<str:site>/versions", views.VersionsView.as_view(), name="map-versions"),
    path("maps/<str:site>/versions/<int:number>", views.VersionView.as_view(), name="map-version"),
    path(
        "maps/<str:site>/versions/<int:number>/restore",
        views.RestoreView.as_view(),
        name="map-restore",
    ),
]
