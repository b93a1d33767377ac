import time

from django.conf import settings
from django.db import transaction
from drf_spectacular.utils import OpenApiResponse, extend_schema
from rest_framework import exceptions, status
from rest_framework.renderers import JSONRenderer
from rest_framework.response import Response
from rest_framework.views import APIView

from boards.heartbeat_sql import robot_by_token_locked
from boards.metrics import heartbeat_interval_told_observe, heartbeat_observe
from boards.protocol import heartbeat_reply_wire
from boards.serializers import (
    HeartbeatResponseSerializer,
    HeartbeatSerializer,
    heartbeat_validate,
)
from boards.services import HeartbeatRejected, heartbeat_apply
from core.commits import relaxed_commit_unless_written
from core.errors import ErrorSerializer
from core.jsonbody import json_parse
from core.negotiation import JsonOnly
from core.overload import request_waited
from robots.authentication import IsRobotInUrl, RobotTokenLockingAuthentication
from robots.mapcache import site_map
from robots.models import PresenceChange, Robot, RobotActivity, RobotBoot

# What a heartbeat writes that its robot's next heartbeat writes again: lost in a database
# crash, nothing is lost (core/commits.py). A heartbeat that wrote anything else (its events,
# acks or requests, a message posted, a task moved) commits durably as always.
REWRITTEN_BY_NEXT_HEARTBEAT = frozenset(
    model._meta.db_table for model in (Robot, PresenceChange, RobotActivity, RobotBoot)
)


class PayloadTooLarge(exceptions.APIException):
    status_code = status.HTTP_413_REQUEST_ENTITY_TOO_LARGE
    default_detail = "request body is over the limit"
    default_code = "too_large"


def read_json_body(request, *, limit: int):
    """The body parsed as JSON whatever its content type, refusing more than `limit` bytes."""
    declared = request.META.get("CONTENT_LENGTH") or ""
    if declared.isdigit() and int(declared) > limit:
        raise PayloadTooLarge(f"body of {declared} bytes is over the {limit}-byte limit")
    if not declared and request.META.get("wsgi.input_terminated"):
        # A chunked body (no Content-Length), which Django would read as empty; the server
        # (gunicorn) has de-chunked it and marks where it ends.
        raw = request.META["wsgi.input"].read(limit + 1)
    else:
        raw = request.read(limit + 1)
    if len(raw) > limit:
        raise PayloadTooLarge(f"body is over the {limit}-byte limit")
    return json_parse(raw)


class HeartbeatAuthentication(RobotTokenLockingAuthentication):
    """The robot found by its token and locked by the heartbeat's own statement
    (boards/heartbeat_sql.py)."""

    def robot_find(self, token: str):
        return robot_by_token_locked(token)


class HeartbeatView(APIView):
    """A robot reports its state and events and receives what is on its message board.

    One transaction per heartbeat, opened before authentication so that the query finding the
    robot by its token also locks its row (one query fewer on the robots' hot path). Nothing
    of a refused heartbeat is kept. A heartbeat that only reported its state commits without
    waiting for the disk, in the same round trip as its `SET LOCAL` (core/commits.py).
    """

    authentication_classes = [HeartbeatAuthentication]
    permission_classes = [IsRobotInUrl]
    parser_classes = []  # read_json_body parses, to enforce the protocol's size limit
    renderer_classes = [JSONRenderer]
    content_negotiation_class = JsonOnly

    def dispatch(self, request, *args, **kwargs):
        started = time.perf_counter()
        stamp = request.META.get("HTTP_X_REQUEST_START")  # set by the proxy (nginx)
        request.waited = request_waited(stamp, now=time.time())
        # The relaxed commit last in the transaction: it commits a plain heartbeat itself.
        with (
            transaction.atomic(),
            relaxed_commit_unless_written(tables=REWRITTEN_BY_NEXT_HEARTBEAT),
        ):
            response = super().dispatch(request, *args, **kwargs)
            if response.status_code >= 400:
                transaction.set_rollback(True)
        seconds = time.perf_counter() - started  # the commit included
        heartbeat_observe(status_code=response.status_code, seconds=seconds)
        return response

    @extend_schema(
        operation_id="robot_heartbeat",
        request={"application/json": HeartbeatSerializer},
        responses={
            200: HeartbeatResponseSerializer,
            400: OpenApiResponse(ErrorSerializer, description="malformed; nothing applied"),
            401: OpenApiResponse(ErrorSerializer, description="missing or wrong token"),
            403: OpenApiResponse(ErrorSerializer, description="another robot's token"),
            413: OpenApiResponse(ErrorSerializer, description="body over 64 KiB"),
        },
        tags=["robots"],
    )
    def post(self, request, robot):
        robot = request.auth  # locked
        body = read_json_body(request, limit=settings.HEARTBEAT_MAX_BYTES)
        heartbeat = heartbeat_validate(body, site_map(robot.site))
        try:
            reply = heartbeat_apply(robot=robot, heartbeat=heartbeat, waited=request.waited)
        except HeartbeatRejected as rejected:
            raise exceptions.ValidationError(rejected.errors) from None
        heartbeat_interval_told_observe(reply.heartbeat_interval)
        return Response(heartbeat_reply_wire(reply))
