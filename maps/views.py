"""The map editor's JSON API (administrators: staff users): the draft, its check, publishing
and rolling back. Thin: each view parses, calls one service, answers."""

from django.shortcuts import get_object_or_404
from drf_spectacular.utils import OpenApiResponse, extend_schema
from rest_framework import exceptions, status
from rest_framework.response import Response
from rest_framework.views import APIView

from core.errors import ErrorSerializer, error_response
from maps import serializers as s
from maps.models import MapVersion
from maps.services import (
    MapBlocked,
    MapInvalid,
    StaleRevision,
    draft_check,
    draft_open,
    draft_publish,
    draft_reset,
    draft_rollout_set,
    draft_save,
    draft_upload,
    version_get,
    version_restore,
)
from robots.models import Site

ERRORS = {
    400: OpenApiResponse(ErrorSerializer, description="invalid; nothing changed"),
    403: OpenApiResponse(ErrorSerializer, description="not an administrator (staff user)"),
    404: OpenApiResponse(ErrorSerializer, description="no such site or version"),
    409: OpenApiResponse(ErrorSerializer, description="the draft changed, or robots block it"),
}


class MapView(APIView):
    """A site's map; staff users only (the API's default permission)."""

    def site(self, code: str) -> Site:
        return get_object_or_404(Site, code=code)

    def handle_exception(self, exc):
        if isinstance(exc, MapInvalid):
            detail = s.problems_by_place(exc.problems, field=exc.field)
            return error_response("invalid", detail, status.HTTP_400_BAD_REQUEST)
        if isinstance(exc, StaleRevision):
            detail = {"revision": [f"the draft is now at revision {exc.current}: read it again"]}
            return error_response("conflict", detail, status.HTTP_409_CONFLICT)
        if isinstance(exc, MapBlocked):
            return error_response("blocked", exc.impact.wire(), status.HTTP_409_CONFLICT)
        if isinstance(exc, MapVersion.DoesNotExist):
            exc = exceptions.NotFound("no such map version")
        return super().handle_exception(exc)

    def valid(self, serializer_class, request):
        serializer = serializer_class(data=request.data)
        serializer.is_valid(raise_exception=True)
        return serializer.validated_data


class DraftView(MapView):
    @extend_schema(
        summary="The site's map draft (a site file)", responses={200: s.DraftSerializer, **ERRORS}
    )
    def get(self, request, site):
        return Response(s.draft_wire(draft_open(site=self.site(site))))

    @extend_schema(
        summary="Replace the draft",
        request=s.DraftSaveSerializer,
        responses={200: s.DraftSerializer, **ERRORS},
    )
    def put(self, request, site):
        data = self.valid(s.DraftSaveSerializer, request)
        draft = draft_save(site=self.site(site), user=request.user, **data)
        return Response(s.draft_wire(draft))


class DraftCheckView(MapView):
    @extend_schema(
        summary="The draft's problems, its changes against the live map, and the robots' "
        "routes and deliveries they touch",
        responses={200: s.CheckSerializer, **ERRORS},
    )
    def get(self, request, site):
        return Response(s.check_wire(draft_check(site=self.site(site))))


class DraftUploadView(MapView):
    @extend_schema(
        summary="A site file as the draft",
        request=s.DraftUploadSerializer,
        responses={200: s.DraftSerializer, **ERRORS},
    )
    def post(self, request, site):
        data = self.valid(s.DraftUploadSerializer, request)
        return Response(s.draft_wire(draft_upload(site=self.site(site), user=request.user, **data)))


class DraftResetView(MapView):
    @extend_schema(
        summary="Discard the draft's edits",
        request=s.RevisionSerializer,
        responses={200: s.DraftSerializer, **ERRORS},
    )
    def post(self, request, site):
        data = self.valid(s.RevisionSerializer, request)
        return Response(s.draft_wire(draft_reset(site=self.site(site), user=request.user, **data)))


class RolloutView(MapView):
    @extend_schema(
        summary="Refuse or re-plan when a new map cuts routes",
        request=s.RolloutSerializer,
        responses={200: s.DraftSerializer, **ERRORS},
    )
    def put(self, request, site):
        data = self.valid(s.RolloutSerializer, request)
        draft = draft_rollout_set(site=self.site(site), user=request.user, **data)
        return Response(s.draft_wire(draft))


class PublishView(MapView):
    @extend_schema(
        summary="Publish the draft as a new map version",
        request=s.PublishSerializer,
        responses={201: s.VersionSerializer, **ERRORS},
    )
    def post(self, request, site):
        data = self.valid(s.PublishSerializer, request)
        version = draft_publish(site=self.site(site), user=request.user, **data)
        return Response(s.version_wire(version), status=status.HTTP_201_CREATED)


class VersionsView(MapView):
    @extend_schema(
        summary="Published map versions, newest first",
        responses={200: s.VersionSerializer(many=True), **ERRORS},
    )
    def get(self, request, site):
        versions = MapVersion.objects.filter(site=self.site(site)).select_related("author")
        return Response([s.version_wire(version) for version in versions])


class VersionView(MapView):
    @extend_schema(
        summary="One published version with its site file",
        responses={200: s.VersionDocumentSerializer, **ERRORS},
    )
    def get(self, request, site, number):
        version = version_get(site=self.site(site), number=number)
        return Response({**s.version_wire(version), "document": version.document})


class RestoreView(MapView):
    @extend_schema(
        summary="Roll back: publish an older version again",
        request=s.RestoreSerializer,
        responses={201: s.VersionSerializer, **ERRORS},
    )
    def post(self, request, site, number):
        data = self.valid(s.RestoreSerializer, request)
        version = version_restore(site=self.site(site), number=number, user=request.user, **data)
        return Response(s.version_wire(version), status=status.HTTP_201_CREATED)
