"""A simulated VDA 5050 (2.0) vehicle: it speaks MQTT to a master control, nothing else.

It knows its map (the site file, as robots.router.SiteMap, for how long each edge takes), its
dock, and the orders and instant actions it receives. It drives the released part of its order
(the base) node by node and stops at the base's end until an order update releases more; at a
node with `pick` or `drop` actions it waits for the staff (a random delay) and reports the
action FINISHED, with the load on board in `loads`. `startPause`/`stopPause` hold it at the next
node; `cancelOrder` ends its order at the next node. A new order is accepted only when it has
no order left to drive (the standard's rule; master control cancels first).

It publishes `connection` ONLINE (retained) on connecting, with CONNECTIONBROKEN as its last
will, its `factsheet` (retained; again on `factsheetRequest`) listing `actions`, and `state` on
every change and every `state_every` real seconds. `break_connection()`
drops the network without a goodbye, so the broker sends the last will.
"""

from __future__ import annotations

import json
import logging
import random
import socket
import threading
import time
from dataclasses import dataclass
from datetime import UTC, datetime

import paho.mqtt.client as mqtt

from robots.router import Router, SiteMap

logger = logging.getLogger("robotsim.vda5050")

VERSION = "2.0.0"
ACTION_DONE = {"FINISHED", "FAILED"}
# What it can do, as its factsheet lists it: pick and drop with 2.0's two listed parameters.
ACTIONS = (
    "pick",
    "drop",
    "initPosition",
    "startPause",
    "stopPause",
    "cancelOrder",
    "stateRequest",
    "factsheetRequest",
)
INSTANT_ONLY = {"startPause", "stopPause", "cancelOrder", "stateRequest", "factsheetRequest"}
SPEED_MAX = 1.5  # metres per second


def _now_wire() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


@dataclass
class _Motion:
    node: dict
    ends: float


class VdaVehicle:
    def __init__(
        self,
        *,
        site_map: SiteMap,
        manufacturer: str,
        serial_number: str,
        dock: str,
        host: str = "127.0.0.1",
        port: int = 1883,
        interface: str = "uagv",
        speedup: float = 1.0,
        staff_delay: tuple[float, float] = (15.0, 60.0),
        state_every: float = 1.0,
        rng: random.Random | None = None,
        actions: tuple[str, ...] | None = ACTIONS,
    ):
        self.map = site_map
        self.router = Router(site_map)
        self.manufacturer, self.serial_number = manufacturer, serial_number
        self.dock = dock
        self.host, self.port = host, port
        self.prefix = f"{interface}/v2/{manufacturer}/{serial_number}"
        self.speedup = speedup
        self.staff_delay = staff_delay
        self.state_every = state_every
        self.rng = rng or random.Random()
        self.supported = actions  # None: it publishes no factsheet
        self.lock = threading.RLock()
        # What the vehicle is doing (under self.lock).
        self.order_id, self.update_id = "", 0
        self.last_node, self.last_seq = dock, 0
        home = site_map.waypoints[dock]
        self.position = (home.x, home.y, home.floor)  # x, y, mapId: nodes off the map have one
        self.nodes: list[dict] = []  # not yet reached, in order
        self.edges: list[dict] = []
        self.actions: dict[str, dict] = {}  # actionId -> its state
        self.running: tuple[str, float] | None = None  # actionId, when the staff are done
        self.motion: _Motion | None = None
        self.paused = False
        self.loads: list[dict] = []
        self.battery = 100.0
        self.finished: list[str] = []  # actionIds finished, in order (for tests)
        self.orders: list[dict] = []  # every order received (for tests)
        self.instant: list[list[dict]] = []  # every instantActions' actions (for tests)
        self.headers: dict[str, int] = {}
        self._changed = True
        self._last_state = 0.0
        self._started = time.monotonic()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.client = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, client_id=f"sim-{serial_number}-{id(self):x}"
        )
        self.client.will_set(
            f"{self.prefix}/connection", self._connection("CONNECTIONBROKEN"), qos=1, retain=True
        )
        self.client.on_connect = self._on_connect
        self.client.on_message = self._on_message

    # --- Running ----------------------------------------------------------------------------

    def start(self) -> None:
        self.client.connect(self.host, self.port, keepalive=5)
        self.client.loop_start()
        self._thread = threading.Thread(target=self._loop, name=self.serial_number, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Shut down in an orderly way: OFFLINE, then disconnect (no last will)."""
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=5)
        info = self.client.publish(
            f"{self.prefix}/connection", self._connection("OFFLINE"), qos=1, retain=True
        )
        info.wait_for_publish(timeout=2)
        self.client.disconnect()
        self.client.loop_stop()

    def break_connection(self) -> None:
        """The network goes: the socket closes without DISCONNECT, the broker sends the will."""
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=5)
        sock = self.client.socket()
        self.client.loop_stop()
        if sock is not None:
            sock.shutdown(socket.SHUT_RDWR)
            sock.close()

    def now(self) -> float:
        """Simulated seconds since start."""
        return (time.monotonic() - self._started) * self.speedup

    @property
    def idle_at_dock(self) -> bool:
        with self.lock:
            return not self.nodes and self.motion is None and self.last_node == self.dock

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                self.step()
            except Exception:  # a bug here must show, not kill the vehicle silently
                logger.exception("%s: step failed", self.serial_number)
            self._stop.wait(0.02)

    # --- MQTT -------------------------------------------------------------------------------

    def _on_connect(self, client, userdata, flags, reason_code, properties=None) -> None:
        client.subscribe([(f"{self.prefix}/order", 1), (f"{self.prefix}/instantActions", 1)])
        client.publish(f"{self.prefix}/connection", self._connection("ONLINE"), qos=1, retain=True)
        self._publish_factsheet()
        self._changed = True

    def _on_message(self, client, userdata, message) -> None:
        try:
            body = json.loads(message.payload)
        except ValueError:
            logger.error("%s: not JSON on %s", self.serial_number, message.topic)
            return
        with self.lock:
            if message.topic.endswith("/order"):
                self._order(body)
            elif message.topic.endswith("/instantActions"):
                self.instant.append(body.get("actions", []))
                for action in body.get("actions", []):
                    self._instant(action)
            self._changed = True

    def _header(self, topic: str) -> dict:
        self.headers[topic] = self.headers.get(topic, -1) + 1
        return {
            "headerId": self.headers[topic],
            "timestamp": _now_wire(),
            "version": VERSION,
            "manufacturer": self.manufacturer,
            "serialNumber": self.serial_number,
        }

    def factsheet(self) -> dict:
        """Its factsheet (2.0): the parts a master control checks an order with."""
        parameters = [
            {"key": key, "valueDataType": "STRING", "isOptional": False}
            for key in ("stationType", "loadType")
        ]
        return {
            **self._header("factsheet"),
            "typeSpecification": {
                "seriesName": "robotsim",
                "agvKinematic": "DIFF",
                "agvClass": "CARRIER",
                "maxLoadMass": 20,
                "localizationTypes": ["NATURAL"],
                "navigationTypes": ["AUTONOMOUS"],
            },
            "physicalParameters": {"speedMin": 0.0, "speedMax": SPEED_MAX},
            "protocolFeatures": {
                "optionalParameters": [],
                "agvActions": [
                    {
                        "actionType": kind,
                        "actionScopes": ["INSTANT"] if kind in INSTANT_ONLY else ["NODE"],
                        "actionParameters": parameters if kind in ("pick", "drop") else [],
                    }
                    for kind in self.supported or ()
                ],
            },
        }

    def _publish_factsheet(self) -> None:
        if self.supported is not None:
            body = json.dumps(self.factsheet())
            self.client.publish(f"{self.prefix}/factsheet", body, qos=1, retain=True)

    def _connection(self, state: str) -> str:
        return json.dumps({**self._header("connection"), "connectionState": state})

    # --- Orders and instant actions ---------------------------------------------------------

    def _order(self, order: dict) -> None:
        self.orders.append(order)
        if order["orderId"] == self.order_id:
            if order["orderUpdateId"] > self.update_id:
                self._update(order)
            return
        if self.nodes or self.motion is not None or self.running is not None:
            logger.warning("%s: order %s refused: busy", self.serial_number, order["orderId"])
            return
        first = order["nodes"][0] if order["nodes"] else None
        if first is None or first["nodeId"] != self.last_node:
            logger.warning("%s: order %s does not start here", self.serial_number, order["orderId"])
            return
        self.order_id, self.update_id = order["orderId"], order["orderUpdateId"]
        self.nodes, self.edges = list(order["nodes"]), list(order["edges"])
        self.last_seq = first["sequenceId"]
        self.actions = {
            a["actionId"]: {
                "actionId": a["actionId"],
                "actionType": a["actionType"],
                "actionStatus": "WAITING",
            }
            for node in order["nodes"]
            for a in node["actions"]
        }

    def _update(self, order: dict) -> None:
        """The update starts at the old base's end: replace the horizon from there on."""
        start = order["nodes"][0]["sequenceId"]
        self.nodes = [n for n in self.nodes if n["sequenceId"] < start] + [
            n for n in order["nodes"] if n["sequenceId"] > self.last_seq
        ]
        self.edges = [e for e in self.edges if e["sequenceId"] < start] + [
            e for e in order["edges"] if e["sequenceId"] > self.last_seq
        ]
        self.update_id = order["orderUpdateId"]
        for node in order["nodes"]:
            for a in node["actions"]:
                self.actions.setdefault(
                    a["actionId"],
                    {
                        "actionId": a["actionId"],
                        "actionType": a["actionType"],
                        "actionStatus": "WAITING",
                    },
                )

    def _instant(self, action: dict) -> None:
        kind = action["actionType"]
        if kind == "startPause":
            self.paused = True
        elif kind == "stopPause":
            self.paused = False
        elif kind == "factsheetRequest":
            self._publish_factsheet()
        elif kind == "cancelOrder":
            # Ends at the node it is driving to; actions not started fail.
            self.nodes = [self.motion.node] if self.motion else []
            self.edges = []
            for state in self.actions.values():
                if state["actionStatus"] == "WAITING":
                    state["actionStatus"] = "FAILED"
        self.actions[action["actionId"]] = {
            "actionId": action["actionId"],
            "actionType": kind,
            "actionStatus": "FINISHED",
        }

    # --- Driving ----------------------------------------------------------------------------

    def step(self) -> None:
        with self.lock:
            self._advance(self.now())
            due = time.monotonic() - self._last_state >= self.state_every
            if self._changed or due:
                self._publish_state()

    def _advance(self, now: float) -> None:
        if self.running is not None:
            action_id, done_at = self.running
            if now < done_at:
                return
            self._finish(action_id)
            if self.running is not None:
                return  # the node's next action
        if self.motion is not None:
            if now < self.motion.ends:
                return
            self._arrive(self.motion.node)
            self.motion = None
            return
        if self.paused or not self.nodes:
            if not self.nodes and self.last_node == self.dock:
                self.battery = min(100.0, self.battery + 0.01)
            return
        node = self.nodes[0]
        if node["sequenceId"] == self.last_seq and node["nodeId"] == self.last_node:
            self._arrive(node)  # an order's first node: where the vehicle already is
        elif node["released"]:
            seconds = self._travel_time(node)
            self.motion = _Motion(node, now + seconds)
            self.battery = max(0.0, self.battery - 0.05)
            self._changed = True

    def _arrive(self, node: dict) -> None:
        self.nodes.remove(node)
        self.edges = [e for e in self.edges if e["sequenceId"] > node["sequenceId"]]
        self.last_node, self.last_seq = node["nodeId"], node["sequenceId"]
        if position := node.get("nodePosition"):
            self.position = (position["x"], position["y"], position["mapId"])
        for action in node["actions"]:
            if self.actions.get(action["actionId"], {}).get("actionStatus") == "WAITING":
                self._start_action(action["actionId"])
                break  # HARD blocking: one at a time; the next starts when this one is done
        self._changed = True

    def _travel_time(self, node: dict) -> float:
        """Along the map; into or out of a lift's car (a node off the map), a second: the car
        itself has moved before the order lets the vehicle out."""
        if self.last_node in self.map.waypoints and node["nodeId"] in self.map.waypoints:
            return self.router.travel_time(self.last_node, node["nodeId"])
        return 1.0

    def _finish(self, action_id: str) -> None:
        state = self.actions.get(action_id, {})
        self.running = None
        if state.get("actionStatus") == "RUNNING":
            state["actionStatus"] = "FINISHED"
            self.finished.append(action_id)
            if state["actionType"] == "pick":
                self.loads.append({"loadId": action_id.split("/")[2]})
            elif state["actionType"] == "drop":
                task = action_id.split("/")[2]
                for load in self.loads:
                    if load["loadId"] == task:
                        self.loads.remove(load)
                        break
        waiting = [
            a
            for a in self._node_actions(self.last_seq)
            if self.actions.get(a["actionId"], {}).get("actionStatus") == "WAITING"
        ]
        if waiting:
            self._start_action(waiting[0]["actionId"])
        self._changed = True

    def _start_action(self, action_id: str) -> None:
        self.actions[action_id]["actionStatus"] = "RUNNING"
        self.running = (action_id, self.now() + self.rng.uniform(*self.staff_delay))

    def _node_actions(self, seq: int) -> list[dict]:
        for order in reversed(self.orders):
            if order["orderId"] != self.order_id:
                continue
            for node in order["nodes"]:
                if node["sequenceId"] == seq:
                    return node["actions"]
        return []

    # --- State ------------------------------------------------------------------------------

    def state(self) -> dict:
        x, y, map_id = self.position
        return {
            **self._header("state"),
            "orderId": self.order_id,
            "orderUpdateId": self.update_id,
            "lastNodeId": self.last_node,
            "lastNodeSequenceId": self.last_seq,
            "driving": self.motion is not None,
            "paused": self.paused,
            "operatingMode": "AUTOMATIC",
            "nodeStates": [
                {"nodeId": n["nodeId"], "sequenceId": n["sequenceId"], "released": n["released"]}
                for n in self.nodes
            ],
            "edgeStates": [
                {"edgeId": e["edgeId"], "sequenceId": e["sequenceId"], "released": e["released"]}
                for e in self.edges
            ],
            "agvPosition": {
                "x": x,
                "y": y,
                "theta": 0.0,
                "mapId": map_id,
                "positionInitialized": True,
            },
            "loads": list(self.loads),
            "actionStates": list(self.actions.values()),
            "batteryState": {
                "batteryCharge": round(self.battery, 2),
                "charging": not self.nodes and self.last_node == self.dock,
            },
            "errors": [],
            "safetyState": {"eStop": "NONE", "fieldViolation": False},
        }

    def _publish_state(self) -> None:
        self.client.publish(f"{self.prefix}/state", json.dumps(self.state()), qos=1)
        self._changed = False
        self._last_state = time.monotonic()
