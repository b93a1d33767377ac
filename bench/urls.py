"""URLconf of the benchmark stack (bench/wsgi.py): the project's URLs plus two endpoints the
heartbeat is compared with.

`POST /bench/bare` is the least a DRF view can do: no authentication, no parsing, no database,
an empty JSON object back. bench/heartbeat.py offers it the same load as the heartbeat, so the
ratio says what the heartbeat's own work costs on top of Django + DRF + gunicorn.

`POST /bench/floor/<code>` (bench/heartbeat.py --floor) is the least a heartbeat kept in the
database can do: one transaction that finds the robot by its token and locks its row, writes
its state and presence, reads its board and commits as the heartbeat commits
(core/commits.py), in plain SQL, validating nothing. Between the bare endpoint and it lies
the price of that transaction on the machine; between it and the heartbeat, the heartbeat's
own code.
"""

import json
from datetime import timedelta

from django.db import connection, transaction
from django.urls import path
from django.utils import timezone
from rest_framework.permissions import AllowAny
from rest_framework.response import Response
from rest_framework.views import APIView

from core.commits import relaxed_commit_unless_written
from core.tokens import bearer_token, token_hash
from hospital_delivery.urls import urlpatterns as project_urlpatterns


class BareView(APIView):
    authentication_classes = []
    permission_classes = [AllowAny]

    def post(self, request):
        return Response({})


class FloorView(APIView):
    authentication_classes = []
    permission_classes = [AllowAny]

    def post(self, request, code):
        token = bearer_token(request.META.get("HTTP_AUTHORIZATION")) or ""
        heartbeat = json.loads(request.body)
        state, now = heartbeat["state"], timezone.now()
        with (
            transaction.atomic(),
            relaxed_commit_unless_written(tables=frozenset({"robots_robot"})),
            connection.cursor() as cursor,
        ):
            cursor.execute(_ROBOT_LOCKED, [token_hash(token)])
            found = cursor.fetchone()
            if found is None:
                return Response(status=401)
            robot_id = found[0]
            # Online for three intervals of 1 s, as Robot.mark_seen keeps a robot told 1 s.
            cursor.execute(
                _ROBOT_SEEN,
                [
                    *(state["status"], state.get("x"), state.get("y"), state.get("heading")),
                    *(state["battery"], state["load"], state["plan_version"], now),
                    *(heartbeat["boot_id"], heartbeat["seq"], now),
                    *(now + timedelta(seconds=3), now + timedelta(seconds=60), robot_id),
                ],
            )
            cursor.execute(_BOARD, [robot_id])
            messages = [{"id": pk, "type": kind, "body": body} for pk, kind, body in cursor]
        return Response({"server_time": now, "heartbeat_interval": 1.0, "messages": messages})


_ROBOT_LOCKED = "SELECT id FROM robots_robot WHERE token_hash = %s FOR NO KEY UPDATE"
_ROBOT_SEEN = (
    "UPDATE robots_robot SET status = %s, x = %s, y = %s, heading = %s, battery = %s, "
    "load = %s, plan_version = %s, reported_at = %s, boot_id = %s, seq = %s, "
    "presence = 'online', last_seen_at = %s, unreachable_at = %s, offline_at = %s WHERE id = %s"
)
_BOARD = (
    "SELECT id, type, body FROM boards_boardmessage "
    "WHERE robot_id = %s AND acked_at IS NULL AND withdrawn_at IS NULL ORDER BY id"
)

urlpatterns = [
    path("bench/floor/<str:code>", FloorView.as_view(), name="bench-floor"),
    path("bench/bare", BareView.as_view(), name="bench-bare"),
    *project_urlpatterns,
]
