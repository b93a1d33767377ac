from django.shortcuts import get_object_or_404
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework import exceptions, mixins, permissions, status, viewsets
from rest_framework.response import Response
from rest_framework.views import APIView

from core.access import is_operator
from core.errors import ErrorSerializer
from robots.choices import EmergencySource
from robots.membership import may_see_site
from robots.models import Resource, Robot, Site
from robots.selectors import emergency_active
from robots.serializers import RobotSerializer
from scheduling.choices import TaskStatus
from scheduling.models import Task
from scheduling.selectors import task_detail, task_detail_of, task_list
from scheduling.serializers import (
    FireAlarmSerializer,
    FireAlarmStartSerializer,
    LiftPrioritySerializer,
    ResourceOutOfServiceSerializer,
    ResourceServiceSerializer,
    RobotMaintenanceSerializer,
    TaskDetailSerializer,
    TaskRequestSerializer,
    TaskSerializer,
)
from scheduling.services import (
    EmergencyRefused,
    MaintenanceRefused,
    TaskNotCancellable,
    emergency_end,
    emergency_start,
    resource_operator_set_priority,
    resource_operator_set_service,
    robot_maintenance_end,
    robot_maintenance_start,
    task_cancel,
    task_request,
)

ERRORS = {
    400: OpenApiResponse(ErrorSerializer, description="invalid; nothing created"),
    401: OpenApiResponse(ErrorSerializer, description="not authenticated"),
    403: OpenApiResponse(ErrorSerializer, description="not a staff user"),
}


class Conflict(exceptions.APIException):
    status_code = status.HTTP_409_CONFLICT
    default_detail = "the task cannot be changed that way now"
    default_code = "conflict"


class IsStaffOrRequester(permissions.BasePermission):
    """Staff users, or the user who requested the task."""

    def has_permission(self, request, view):
        return bool(request.user and request.user.is_authenticated)

    def has_object_permission(self, request, view, obj):
        return request.user.is_staff or obj.requester_id == request.user.pk


class TaskViewSet(mixins.ListModelMixin, viewsets.GenericViewSet):
    """Delivery tasks: staff users (session or API token) only."""

    serializer_class = TaskSerializer
    lookup_url_kwarg = "code"

    def get_queryset(self):
        return task_list(status=self.request.query_params.get("status"))

    @extend_schema(
        summary="Delivery tasks, newest first",
        parameters=[OpenApiParameter("status", enum=TaskStatus.values, required=False)],
    )
    def list(self, request, *args, **kwargs):
        wanted = request.query_params.get("status")
        if wanted and wanted not in TaskStatus.values:
            raise exceptions.ValidationError({"status": [f"unknown status {wanted!r}"]})
        return super().list(request, *args, **kwargs)

    @extend_schema(
        summary="One task with its stops and history",
        responses={200: TaskDetailSerializer, 404: ErrorSerializer},
    )
    def retrieve(self, request, code):
        task = task_detail(code=code)
        if task is None:
            raise exceptions.NotFound(f"no task {code!r}")
        return Response(TaskDetailSerializer(task).data)

    @extend_schema(
        summary="Request a delivery (with `repeat`, a periodic one: answers its first instance; "
        "a `secure` one's answer alone carries its `pin`)",
        request=TaskRequestSerializer,
        responses={201: TaskDetailSerializer, **ERRORS},
    )
    def create(self, request):
        serializer = TaskRequestSerializer(data=request.data)
        serializer.is_valid(raise_exception=True)
        task = task_request(requester=request.user, **serializer.validated_data)
        detail = TaskDetailSerializer(task_detail_of(task)).data
        if task.secure:  # the only time anyone sees it: only its hash is kept
            detail["pin"] = task.pin_plain
        return Response(detail, status=status.HTTP_201_CREATED)


class TaskCancelView(APIView):
    """Cancel a task (protocol v1 "Cancellation"): by its requester or a staff user."""

    permission_classes = [IsStaffOrRequester]

    @extend_schema(
        operation_id="task_cancel",
        summary="Cancel a task: withdrawn, dropped from its robot's plan, or returned",
        request=None,
        responses={
            200: TaskDetailSerializer,
            **ERRORS,
            404: OpenApiResponse(ErrorSerializer, description="no such task"),
            409: OpenApiResponse(ErrorSerializer, description="delivered, finished or returning"),
        },
        tags=["tasks"],
    )
    def post(self, request, code):
        task = get_object_or_404(Task.objects.with_code(code))
        self.check_object_permissions(request, task)
        try:
            task_cancel(task=task, by=request.user)
        except TaskNotCancellable as refused:
            raise Conflict(str(refused)) from None
        return Response(TaskDetailSerializer(task_detail(code=code)).data)


RESOURCE_ERRORS = {
    **ERRORS,
    404: OpenApiResponse(ErrorSerializer, description="no such site or resource"),
    409: OpenApiResponse(ErrorSerializer, description="already out of (or in) service"),
}


class ResourceListView(APIView):
    """A site's elevators, doors and corridors with their service state: staff users only."""

    @extend_schema(
        operation_id="resource_list",
        summary="A site's elevators, doors and corridors, and whether each is in service",
        responses={200: ResourceServiceSerializer(many=True), **RESOURCE_ERRORS},
        tags=["resources"],
    )
    def get(self, request, site):
        resources = Resource.objects.filter(site__code=site).select_related("site")
        if not resources and not Site.objects.filter(code=site).exists():
            raise exceptions.NotFound(f"no site {site!r}")
        return Response(ResourceServiceSerializer(resources, many=True).data)


class ResourceOutOfServiceView(APIView):
    """Take a resource out of service (an operator's action, recorded)."""

    @extend_schema(
        operation_id="resource_out_of_service",
        summary="Take an elevator, door or corridor out of service: nobody is granted it, "
        "routes avoid it, waiting robots are told",
        request=ResourceOutOfServiceSerializer,
        responses={200: ResourceServiceSerializer, **RESOURCE_ERRORS},
        tags=["resources"],
    )
    def post(self, request, site, code):
        resource = _resource(site, code)
        form = ResourceOutOfServiceSerializer(data=request.data)
        form.is_valid(raise_exception=True)
        reason = form.validated_data["reason"]
        done = resource_operator_set_service(
            resource=resource, in_service=False, by=request.user, reason=reason
        )
        if done is None:
            raise Conflict(f"{code} is already out of service")
        return Response(ResourceServiceSerializer(_resource(site, code)).data)


class ResourceReturnToServiceView(APIView):
    """Return a resource to service: its queue is granted in order."""

    @extend_schema(
        operation_id="resource_return_to_service",
        summary="Return an elevator, door or corridor to service",
        request=None,
        responses={200: ResourceServiceSerializer, **RESOURCE_ERRORS},
        tags=["resources"],
    )
    def post(self, request, site, code):
        resource = _resource(site, code)
        done = resource_operator_set_service(resource=resource, in_service=True, by=request.user)
        if done is None:
            raise Conflict(f"{code} is in service")
        return Response(ResourceServiceSerializer(_resource(site, code)).data)


def _resource(site: str, code: str) -> Resource:
    found = Resource.objects.select_related("site").filter(site__code=site, code=code).first()
    if found is None:
        raise exceptions.NotFound(f"no resource {code!r} at site {site!r}")
    return found


class IsOperator(permissions.BasePermission):
    """Operators and staff users (a building management system signs in as an operator)."""

    def has_permission(self, request, view):
        return is_operator(request.user)


FIRE_ALARM_ERRORS = {
    **ERRORS,
    403: OpenApiResponse(ErrorSerializer, description="not an operator nor a staff user"),
    404: OpenApiResponse(ErrorSerializer, description="no such site (or not the user's)"),
    409: OpenApiResponse(ErrorSerializer, description="already in force (or none in force)"),
}


class FireAlarmView(APIView):
    """A site's fire alarm: read it, or start it (robots on its floors stop, no lift is
    granted, deliveries are held until the all-clear)."""

    permission_classes = [IsOperator]

    @extend_schema(
        operation_id="fire_alarm_read",
        summary="Whether a fire alarm is in force at the site, and where",
        responses={200: FireAlarmSerializer, **FIRE_ALARM_ERRORS},
        tags=["emergencies"],
    )
    def get(self, request, site):
        found = _site(request, site)
        return Response(FireAlarmSerializer.of(found, emergency_active(site=found)))

    @extend_schema(
        operation_id="fire_alarm_start",
        summary="Start a fire alarm on some floors of the site, or all of them",
        request=FireAlarmStartSerializer,
        responses={201: FireAlarmSerializer, **FIRE_ALARM_ERRORS},
        tags=["emergencies"],
    )
    def post(self, request, site):
        found = _site(request, site)
        form = FireAlarmStartSerializer(data=request.data)
        form.is_valid(raise_exception=True)
        try:
            emergency = emergency_start(
                site=found, **form.validated_data, via=EmergencySource.API, by=request.user
            )
        except EmergencyRefused as refused:
            raise _refusal(refused) from None
        data = FireAlarmSerializer.of(found, emergency)
        return Response(data, status=status.HTTP_201_CREATED)


class FireAlarmAllClearView(APIView):
    """The all-clear: robots resume, lifts are granted again, held deliveries are allocated."""

    permission_classes = [IsOperator]

    @extend_schema(
        operation_id="fire_alarm_all_clear",
        summary="End the site's fire alarm",
        request=None,
        responses={200: FireAlarmSerializer, **FIRE_ALARM_ERRORS},
        tags=["emergencies"],
    )
    def post(self, request, site):
        found = _site(request, site)
        try:
            ended = emergency_end(site=found, via=EmergencySource.API, by=request.user)
        except EmergencyRefused as refused:
            raise _refusal(refused) from None
        return Response(FireAlarmSerializer.of(found, ended.emergency))


def _site(request, code: str) -> Site:
    found = Site.objects.filter(code=code).first()
    if found is None or not may_see_site(request.user, found.pk):
        raise exceptions.NotFound(f"no site {code!r}")
    return found


def _refusal(refused: EmergencyRefused | MaintenanceRefused) -> exceptions.APIException:
    if refused.field is not None:
        return exceptions.ValidationError({refused.field: [str(refused)]})
    return Conflict(str(refused))


MAINTENANCE_ERRORS = {
    **ERRORS,
    404: OpenApiResponse(ErrorSerializer, description="no such robot"),
    409: OpenApiResponse(ErrorSerializer, description="already in maintenance (or not)"),
}


class RobotMaintenanceView(APIView):
    """Take a robot out of service for maintenance (an operator's action, recorded)."""

    @extend_schema(
        operation_id="robot_maintenance_start",
        summary="Take a robot out of service for maintenance: its tasks not picked up go to "
        "other robots, what it carries is handed back at the pick-up points",
        request=RobotMaintenanceSerializer,
        responses={200: RobotSerializer, **MAINTENANCE_ERRORS},
        tags=["robots"],
    )
    def post(self, request, robot):
        found = _robot(robot)
        form = RobotMaintenanceSerializer(data=request.data)
        form.is_valid(raise_exception=True)
        try:
            robot_maintenance_start(robot=found, **form.validated_data, by=request.user)
        except MaintenanceRefused as refused:
            raise _refusal(refused) from None
        return Response(RobotSerializer(_robot(robot)).data)


class RobotReturnToServiceView(APIView):
    """Return a robot from maintenance: it is offered tasks again."""

    @extend_schema(
        operation_id="robot_maintenance_end",
        summary="Return a robot from maintenance to service",
        request=None,
        responses={200: RobotSerializer, **MAINTENANCE_ERRORS},
        tags=["robots"],
    )
    def post(self, request, robot):
        try:
            robot_maintenance_end(robot=_robot(robot), by=request.user)
        except MaintenanceRefused as refused:
            raise _refusal(refused) from None
        return Response(RobotSerializer(_robot(robot)).data)


def _robot(code: str) -> Robot:
    found = Robot.objects.select_related("site", "dock").filter(code=code).first()
    if found is None:
        raise exceptions.NotFound(f"no robot {code!r}")
    return found


class LiftPriorityView(APIView):
    """Hold an elevator for an emergency team (operators too: a building management system
    signs in as one): its holder finishes its ride, nobody is granted it until released."""

    permission_classes = [IsOperator]

    @extend_schema(
        operation_id="lift_priority_start",
        summary="Hold an elevator for an emergency team: no robot is granted it until released",
        request=LiftPrioritySerializer,
        responses={200: ResourceServiceSerializer, **RESOURCE_ERRORS},
        tags=["emergencies"],
    )
    def post(self, request, site, code):
        resource = _elevator(request, site, code)
        form = LiftPrioritySerializer(data=request.data)
        form.is_valid(raise_exception=True)
        done = resource_operator_set_priority(
            resource=resource, on=True, by=request.user, reason=form.validated_data["reason"]
        )
        if done is None:
            raise Conflict(f"{code} is already held for an emergency team")
        return Response(ResourceServiceSerializer(_resource(site, code)).data)


class LiftPriorityEndView(APIView):
    """Release an elevator held for an emergency team: its queue is granted in order."""

    permission_classes = [IsOperator]

    @extend_schema(
        operation_id="lift_priority_end",
        summary="Release an elevator held for an emergency team",
        request=None,
        responses={200: ResourceServiceSerializer, **RESOURCE_ERRORS},
        tags=["emergencies"],
    )
    def post(self, request, site, code):
        resource = _elevator(request, site, code)
        if resource_operator_set_priority(resource=resource, on=False, by=request.user) is None:
            raise Conflict(f"{code} is not held for an emergency team")
        return Response(ResourceServiceSerializer(_resource(site, code)).data)


def _elevator(request, site: str, code: str) -> Resource:
    """The site's elevator `code` (404 otherwise, as for a site that is not the user's)."""
    found = _site(request, site)
    resource = _resource(found.code, code)
    if not resource.is_elevator:
        raise exceptions.NotFound(f"{code!r} is not an elevator")
    return resource
