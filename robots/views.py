from drf_spectacular.utils import extend_schema, extend_schema_view
from rest_framework import viewsets

from robots.models import Robot
from robots.serializers import RobotSerializer


@extend_schema_view(
    list=extend_schema(summary="Every robot with its presence and last reported state"),
    retrieve=extend_schema(summary="One robot with its presence and last reported state"),
)
class RobotViewSet(viewsets.ReadOnlyModelViewSet):
    """The device catalog: staff users (session or API token) only."""

    serializer_class = RobotSerializer
    lookup_field = "code"
    lookup_url_kwarg = "robot"
    queryset = Robot.objects.select_related("site", "dock", "floor", "waypoint")
