"""Run the MQTT bridge to the building's lift and door controllers (the Procfile's `building`)."""

import signal

from django.conf import settings
from django.core.management.base import BaseCommand

from building.bridge import MqttBridge


class Command(BaseCommand):
    help = "Drive MQTT lifts and doors: publish the server's requests, apply their states."

    def handle(self, *args, **options):
        if settings.BUILDING_ADAPTER != "mqtt":
            self.stdout.write(f"BUILDING_ADAPTER={settings.BUILDING_ADAPTER}: no MQTT devices.")
            signal.pause()  # stay up, as honcho stops everything when one process exits
            return
        bridge = MqttBridge(
            host=settings.BUILDING_MQTT_HOST,
            port=settings.BUILDING_MQTT_PORT,
            prefix=settings.BUILDING_MQTT_PREFIX,
            client_id="hospital_delivery-building",
        )
        self.stdout.write(f"building bridge on {settings.BUILDING_MQTT_PREFIX}")
        try:
            while True:
                bridge.run_once(wait=0.5)
        finally:
            bridge.close()
