"""manage.py vda5050_bridge: the VDA 5050 master-control bridge, a process of its own
(Procfile `vda5050`)."""

import signal

from django.conf import settings
from django.core.management.base import BaseCommand

from vda5050.bridge import Bridge


class Command(BaseCommand):
    help = "Run the VDA 5050 bridge: VDA 5050 vehicles over MQTT as members of their site's fleet."

    def add_arguments(self, parser):
        parser.add_argument("--host", default=settings.VDA5050_MQTT_HOST)
        parser.add_argument("--port", type=int, default=settings.VDA5050_MQTT_PORT)
        parser.add_argument(
            "--interface",
            default=settings.VDA5050_INTERFACE,
            help="the topics' first level (default: VDA5050_INTERFACE, uagv)",
        )

    def handle(self, *args, host, port, interface, **options):
        bridge = Bridge(host=host, port=port, interface=interface)
        # SIGTERM (honcho, the tests) ends the loop cleanly: disconnect, then loop_forever returns.
        signal.signal(signal.SIGTERM, lambda *_: bridge.client.disconnect())
        try:
            bridge.run_forever()
        except KeyboardInterrupt:
            bridge.client.disconnect()
