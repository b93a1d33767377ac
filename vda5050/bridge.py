"""The VDA 5050 master-control bridge: MQTT in and out, one Link per vehicle.

Topics as the standard names them, `<interface>/<majorVersion>/<manufacturer>/<serialNumber>/
<topic>` (`uagv/v2/Acme/SN-7/state`). The bridge subscribes to every vehicle's `connection` and
`state`, and publishes `order` and `instantActions`. Messages are handled on paho's network
thread, one after another, so one vehicle's heartbeats are applied in order.

A 2.0 vehicle may publish its state only every 30 s when nothing happens, and the board
answers only heartbeats. So a second thread (`tick`) beats for each connected vehicle every
BEAT seconds with its last state: the board's messages (a grant, an operator's Pause) reach
the vehicle within a beat, and a vehicle whose `connection` says it is there stays `online`
as long as its own state interval allows (twice it, and a stateRequest once it is overdue).
Both threads take one lock, so the links see one message or one beat at a time.

A message that is not JSON, fails its schema, names another vehicle than its topic, comes from
a vehicle no robot row declares, or stands for a heartbeat the board refuses, is logged and
counted (vda5050.metrics) and changes nothing; nothing a message does can stop the bridge.
"""

import json
import logging
import threading
import time
import uuid
from datetime import UTC, datetime

import paho.mqtt.client as mqtt
from django.db import close_old_connections, connections

from vda5050 import metrics
from vda5050.link import Link, Outgoing
from vda5050.orders import VehicleOptions
from vda5050.services import (
    HeartbeatRefused,
    vehicle_connection_lost,
    vehicle_factsheet_store,
    vehicle_find,
    vehicle_heartbeat,
    vehicle_held_alert,
    vehicle_held_alert_close,
)
from vda5050.validation import MessageInvalid, message_parse

logger = logging.getLogger("vda5050")

MAJOR_VERSION = "v2"
VERSION = "2.0.0"
QOS = 1
BEAT = 1.0  # seconds between the heartbeats the bridge makes for a quiet vehicle
TICK = 0.2  # how often the beating thread looks


def topic_of(interface: str, manufacturer: str, serial_number: str, topic: str) -> str:
    return f"{interface}/{MAJOR_VERSION}/{manufacturer}/{serial_number}/{topic}"


def wire_time() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


class Bridge:
    def __init__(self, *, host: str, port: int, interface: str):
        self.host, self.port, self.interface = host, port, interface
        self.links: dict[tuple[str, str], Link] = {}
        self.last_header: dict[tuple[str, str], int] = {}
        self.headers: dict[tuple[str, str, str], int] = {}
        self.client = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, client_id=f"hd-bridge-{uuid.uuid4().hex[:10]}"
        )
        self.client.on_connect = self._on_connect
        self.client.on_message = self._on_message
        self.client.on_disconnect = self._on_disconnect
        self.lock = threading.RLock()
        self.stopped = threading.Event()
        self.beats: dict[tuple[str, str], float] = {}  # identity -> when last applied
        self.states: dict[tuple[str, str], float] = {}  # identity -> its last state's arrival
        self.asked: dict[tuple[str, str], float] = {}  # identity -> last stateRequest sent
        self.clock = time.monotonic  # seconds; the tests drive their own
        self.ticker = threading.Thread(target=self._tick_forever, name="vda5050-beat", daemon=True)

    # --- Running ----------------------------------------------------------------------------

    def start(self) -> None:
        """Connect and handle messages on a thread of paho's (tests); stop() ends it."""
        self.client.connect(self.host, self.port, keepalive=10)
        self.client.loop_start()
        self.ticker.start()

    def run_forever(self) -> None:
        """Connect and handle messages until disconnected (the management command)."""
        self.client.connect(self.host, self.port, keepalive=10)
        self.ticker.start()
        self.client.loop_forever(retry_first_connection=True)

    def stop(self) -> None:
        self.stopped.set()
        if self.ticker.is_alive():
            self.ticker.join(timeout=10)
        self.client.disconnect()
        self.client.loop_stop()

    def _tick_forever(self) -> None:
        while not self.stopped.wait(TICK):
            try:
                close_old_connections()
                self.tick()
            except Exception:
                logger.exception("error beating for the vehicles")
        connections.close_all()  # this thread's own

    def tick(self) -> None:
        """Beat for each quiet vehicle that is there; ask one overdue for its state."""
        with self.lock:
            now = self.clock()
            for identity, link in list(self.links.items()):
                if link.last_state is None or not link.connected:
                    continue
                silent = now - self.states.get(identity, now)
                if silent > 2 * link.state_interval:
                    continue  # not heard of for too long: its presence runs out
                if silent > link.state_interval and now - self.asked.get(identity, 0) > BEAT:
                    self.publish(identity, link.instant_actions("stateRequest"))
                if now - self.beats.get(identity, 0) >= BEAT:
                    self._beat(identity, link, link.last_state)

    def _on_connect(self, client, userdata, flags, reason_code, properties=None) -> None:
        if reason_code.is_failure:
            logger.error("MQTT connection refused: %s", reason_code)
            return
        prefix = f"{self.interface}/{MAJOR_VERSION}/+/+"
        client.subscribe(
            [(f"{prefix}/{topic}", QOS) for topic in ("connection", "state", "factsheet")]
        )
        logger.info("VDA 5050 bridge on %s:%s, topics %s/...", self.host, self.port, prefix)

    def _on_disconnect(self, client, userdata, flags, reason_code, properties=None) -> None:
        # On paho's thread, which owns the database connection the handlers used.
        connections.close_all()
        if reason_code.is_failure:
            logger.warning("MQTT connection lost (%s); reconnecting", reason_code)

    def _on_message(self, client, userdata, message) -> None:
        self.handle(message.topic, message.payload)

    # --- Handling one message ---------------------------------------------------------------

    def handle(self, topic: str, payload: bytes) -> None:
        """Apply one message; never raises."""
        parts = topic.split("/")
        kind = parts[-1] if len(parts) == 5 else "unknown"
        try:
            close_old_connections()  # a connection the database dropped is replaced
            with self.lock:
                self._handle(parts, kind, payload)
        except MessageInvalid as invalid:
            logger.warning("dropped a %s message on %s: %s", kind, topic, invalid)
            metrics.message_rejected(topic=kind, reason=invalid.reason)
        except Exception:
            logger.exception("error handling a %s message on %s", kind, topic)
            metrics.message_rejected(topic=kind, reason="error")

    def _handle(self, parts: list[str], kind: str, payload: bytes) -> None:
        if kind not in ("connection", "state", "factsheet"):
            raise MessageInvalid("topic", "not a connection, state or factsheet topic")
        message = message_parse(kind, payload)
        identity = (parts[2], parts[3])
        if (message["manufacturer"], message["serialNumber"]) != identity:
            raise MessageInvalid("identity", "manufacturer/serialNumber differ from the topic's")
        link = self._link(identity)
        if kind == "connection":
            self._connection(link, identity, message)
        elif kind == "factsheet":
            link.factsheet_seen(message)
            vehicle_factsheet_store(robot_id=link.robot_id, factsheet=message)
            logger.info("%s: factsheet", link.robot_code)
        else:
            self._state(link, identity, message)
        metrics.message_applied(topic=kind)

    def _link(self, identity: tuple[str, str]) -> Link:
        link = self.links.get(identity)
        if link is None:
            vehicle = vehicle_find(manufacturer=identity[0], serial_number=identity[1])
            if vehicle is None:
                raise MessageInvalid("unknown_vehicle", f"no robot is vehicle {identity}")
            link = self.links[identity] = Link(
                robot_id=vehicle.robot_id,
                robot_code=vehicle.code,
                dock=vehicle.dock,
                site_map=vehicle.site_map,
                router=vehicle.router,
                options=VehicleOptions.from_site(vehicle.options),
                lifts_by_car=vehicle.lifts_by_car,
                factsheet=vehicle.factsheet,
            )
            if vehicle.plan is not None:
                link.resume(vehicle.plan)
        return link

    def _connection(self, link: Link, identity: tuple[str, str], message: dict) -> None:
        state = message["connectionState"]
        logger.info("%s: connection %s", link.robot_code, state)
        link.connection = state
        if state == "ONLINE":
            self.last_header.pop(identity, None)  # a restarted vehicle counts from 0 again
            return
        presence = vehicle_connection_lost(robot_id=link.robot_id, graceful=state == "OFFLINE")
        logger.info("%s: now %s", link.robot_code, presence)

    def _state(self, link: Link, identity: tuple[str, str], message: dict) -> None:
        last = self.last_header.get(identity)
        if last is not None and message["headerId"] <= last:
            raise MessageInvalid("stale", f"headerId {message['headerId']} after {last}")
        self.last_header[identity] = message["headerId"]
        now, previous = self.clock(), self.states.get(identity)
        if previous is not None and link.connected:
            link.state_gap(now - previous)
        self.states[identity] = now
        link.connection = "ONLINE"  # a state says it is there, whatever a last will said
        self._beat(identity, link, message)
        ask = link.factsheet_request()  # one not retained on the broker: asked for once
        if ask is not None:
            self.publish(identity, ask)

    def _beat(self, identity: tuple[str, str], link: Link, state: dict) -> None:
        self.beats[identity] = self.clock()
        try:
            messages = self._apply(link, link.heartbeat(state))
        except Exception:
            link.last_state = None  # not beaten with again: only a state the board took is
            raise
        for outgoing in link.messages(messages):
            self.publish(identity, outgoing)
        for crossing in link.held_at_lift(self.clock()):
            logger.error("%s: held at %s, the car not come", link.robot_code, crossing.resource)
            vehicle_held_alert(
                robot_id=link.robot_id,
                lift=crossing.resource,
                floor=crossing.from_floor,
                seconds=self.clock() - crossing.held_since,
            )
        for crossing in link.lift_cars_come():
            vehicle_held_alert_close(
                robot_id=link.robot_id, lift=crossing.resource, floor=crossing.from_floor
            )

    def _apply(self, link: Link, heartbeat: dict) -> list[dict]:
        try:
            messages = vehicle_heartbeat(robot_id=link.robot_id, heartbeat=heartbeat)
        except HeartbeatRefused as refused:
            # As a robot does: drop the events and requests named, send the rest at once.
            if not link.drop_refused(list(refused.errors)):
                raise MessageInvalid("refused", json.dumps(refused.errors)[:300]) from None
            heartbeat = {**heartbeat, "events": link.events, "requests": link.requests}
            messages = vehicle_heartbeat(robot_id=link.robot_id, heartbeat=heartbeat)
        link.applied()
        return messages

    # --- Publishing -------------------------------------------------------------------------

    def publish(self, identity: tuple[str, str], outgoing: Outgoing) -> None:
        manufacturer, serial_number = identity
        key = (manufacturer, serial_number, outgoing.topic)
        self.headers[key] = self.headers.get(key, -1) + 1
        body = {
            "headerId": self.headers[key],
            "timestamp": wire_time(),
            "version": VERSION,
            "manufacturer": manufacturer,
            "serialNumber": serial_number,
            **outgoing.body,
        }
        topic = topic_of(self.interface, manufacturer, serial_number, outgoing.topic)
        if outgoing.topic == "instantActions":
            self.asked[identity] = self.clock()
        self.client.publish(topic, json.dumps(body), qos=QOS)
