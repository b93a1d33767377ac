from django.shortcuts import get_object_or_404
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework import exceptions, mixins, permissions, status, viewsets
from rest_framework.response import Response
from rest_framework.views import APIView

from core.errors import ErrorSerializer
from scheduling.choices import TaskStatus
from scheduling.models import Task
from scheduling.selectors import task_detail, task_list
from scheduling.serializers import TaskDetailSerializer, TaskRequestSerializer, TaskSerializer
from scheduling.services import TaskNotCancellable, task_cancel, task_request

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
        detail = TaskDetailSerializer(task_detail(code=task.code)).data
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
