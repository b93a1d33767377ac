"""The MQTT bridge to a building's lift and door controllers (`manage.py building_bridge`).

One process: paho's network thread only queues what it receives; the bridge's own loop
applies states (database work) and publishes requests not sent yet, so a slow database never
blocks the MQTT connection and every database write happens on one thread.
"""

import json
import logging
import queue
from dataclasses import dataclass, field

import paho.mqtt.client as mqtt
from django.db import transaction
from django.utils import timezone

from building.adapters import mqtt as wire
from building.choices import AdapterKind
from building.models import Device
from building.services import Report, device_report, fire_panel_report
from robots.models import Floor, Site

logger = logging.getLogger(__name__)

LIFT_STATES, DOOR_STATES, FIRE_PANEL = "lift_states", "door_states", "fire_panel"


@dataclass
class BridgeCounts:
    published: int = 0
    applied: int = 0
    invalid: int = 0
    unknown: int = 0
    reasons: list[str] = field(default_factory=list)


class MqttBridge:
    def __init__(self, *, host: str, port: int, prefix: str, client_id: str = ""):
        self.prefix = prefix.rstrip("/")
        self.counts = BridgeCounts()
        self._inbox: queue.Queue[tuple[str, bytes]] = queue.Queue()
        self._client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=client_id)
        self._client.on_connect = self._on_connect
        self._client.on_message = self._on_message
        self._client.connect(host, port, keepalive=30)
        self._client.loop_start()

    def close(self) -> None:
        self._client.loop_stop()
        self._client.disconnect()

    # --- paho's thread: queue only -------------------------------------------------------------

    def _on_connect(self, client, userdata, flags, reason_code, properties):
        # (Re)subscribe on every connect: a reconnected session may have lost its subscriptions.
        client.subscribe(
            [
                (f"{self.prefix}/+/{LIFT_STATES}/+", 1),
                (f"{self.prefix}/+/{DOOR_STATES}/+", 1),
                (f"{self.prefix}/+/{FIRE_PANEL}", 1),
            ]
        )

    def _on_message(self, client, userdata, message):
        self._inbox.put((message.topic, message.payload))

    # --- the bridge's loop ---------------------------------------------------------------------

    def run_once(self, *, wait: float = 0.2) -> None:
        """Apply the states received (waiting up to `wait` s for the first), publish requests."""
        try:
            received = [self._inbox.get(timeout=wait)]
        except queue.Empty:
            received = []
        while not self._inbox.empty():
            received.append(self._inbox.get_nowait())
        for topic, payload in received:
            self.apply(topic, payload)
        self.publish_pending()

    def apply(self, topic: str, payload: bytes) -> bool:
        """Apply one state message; a bad one is logged and counted and changes nothing."""
        site = self._fire_panel_site(topic)
        if site is not None:
            return self._fire_panel_apply(topic, payload, site)
        found = self._device_of(topic)
        if found is None:
            self.counts.unknown += 1
            return False
        device, kind = found
        name = device.resource.code
        try:
            if kind == LIFT_STATES:
                report = Report(**wire.lift_state_read(payload, name))
            else:
                report = Report(**wire.door_state_read(payload, name))
            if report.floor is not None and not _floor_known(device, report.floor):
                raise wire.StateInvalid(f"current_floor: no floor {report.floor!r} at this site")
        except wire.StateInvalid as invalid:
            return self._invalid(topic, invalid)
        device_report(device=device, report=report)
        self.counts.applied += 1
        return True

    def _fire_panel_apply(self, topic: str, payload: bytes, site: Site) -> bool:
        try:
            report = wire.fire_panel_read(payload)
            unknown = set(report["floors"]) - set(
                Floor.objects.filter(site=site).values_list("code", flat=True)
            )
            if unknown:
                raise wire.StateInvalid(f"floors: no floor {sorted(unknown)} at this site")
        except wire.StateInvalid as invalid:
            return self._invalid(topic, invalid)
        fire_panel_report(site=site, **report)
        self.counts.applied += 1
        return True

    def _invalid(self, topic: str, invalid: Exception) -> bool:
        self.counts.invalid += 1
        self.counts.reasons.append(f"{topic}: {invalid}")
        logger.warning("invalid state on %s: %s", topic, invalid)
        return False

    def publish_pending(self) -> int:
        """Publish each MQTT device's request not sent yet (retained, QoS 1)."""
        pending = Device.objects.filter(adapter=AdapterKind.MQTT).select_related(
            "resource__site", "requested_floor"
        )
        sent = 0
        for device in pending:
            if device.request_seq > device.sent_seq:
                sent += self._publish(device)
        return sent

    def _publish(self, device: Device) -> bool:
        resource, now = device.resource, timezone.now()
        if resource.is_elevator:
            floor = device.requested_floor.code if device.requested_floor else None
            door = "open" if device.wants_door_open else "closed"
            body = wire.lift_request(
                name=resource.code, session=device.session, floor=floor, door=door, now=now
            )
            kind = "lift_requests"
        else:
            door = "open" if device.wants_door_open else "closed"
            body = wire.door_request(name=resource.code, door=door, now=now)
            kind = "door_requests"
        where = wire.topic(self.prefix, resource.site.code, kind, resource.code)
        info = self._client.publish(where, wire_json(body), qos=1, retain=True)
        info.wait_for_publish(timeout=5)
        # Claimed by a conditional UPDATE: a newer request written meanwhile is sent next pass.
        with transaction.atomic():
            Device.objects.filter(pk=device.pk, sent_seq=device.sent_seq).update(
                sent_seq=device.request_seq
            )
        self.counts.published += 1
        return True

    def _fire_panel_site(self, topic: str) -> Site | None:
        parts = topic[len(self.prefix) + 1 :].split("/") if topic.startswith(self.prefix) else []
        if len(parts) != 2 or parts[1] != FIRE_PANEL:
            return None
        return Site.objects.filter(code=parts[0]).first()

    def _device_of(self, topic: str) -> tuple[Device, str] | None:
        parts = topic[len(self.prefix) + 1 :].split("/") if topic.startswith(self.prefix) else []
        if len(parts) != 3 or parts[1] not in (LIFT_STATES, DOOR_STATES):
            return None
        site, kind, name = parts
        device = (
            Device.objects.filter(
                adapter=AdapterKind.MQTT, resource__site__code=site, resource__code=name
            )
            .select_related("resource__site")
            .first()
        )
        return (device, kind) if device is not None else None


def wire_json(body: dict) -> bytes:
    return json.dumps(body, separators=(",", ":")).encode()


def _floor_known(device: Device, code: str) -> bool:
    return Floor.objects.filter(site_id=device.resource.site_id, code=code).exists()
