"""URLconf of the benchmark stack (bench/wsgi.py): the project's URLs plus a bare endpoint.

`POST /bench/bare` is the least a DRF view can do: no authentication, no parsing, no database,
an empty JSON object back. bench/heartbeat.py offers it the same load as the heartbeat, so the
ratio says what the heartbeat's own work costs on top of Django + DRF + gunicorn.
"""

from django.urls import path
from rest_framework.permissions import AllowAny
from rest_framework.response import Response
from rest_framework.views import APIView

from hospital_delivery.urls import urlpatterns as project_urlpatterns


class BareView(APIView):
    authentication_classes = []
    permission_classes = [AllowAny]

    def post(self, request):
        return Response({})


urlpatterns = [
    path("bench/bare", BareView.as_view(), name="bench-bare"),
    *project_urlpatterns,
]
