"""ASGI entry point. In production it serves only the websockets; HTTP goes to gunicorn (WSGI),
which runs sync views several times faster than an ASGI server can
(docs/architecture/decisions/serving.md)."""

import os

from channels.routing import ProtocolTypeRouter
from django.core.asgi import get_asgi_application

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "hospital_delivery.settings")
django_asgi_app = get_asgi_application()

from hospital_delivery.routing import websocket_application  # noqa: E402  (needs apps loaded)

application = ProtocolTypeRouter(
    {
        "http": django_asgi_app,
        "websocket": websocket_application,
    }
)
