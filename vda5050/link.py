"""One VDA 5050 vehicle as the board sees it: its state messages become heartbeats, its board
messages become orders and instant actions. Pure Python (no database, no MQTT): the bridge
(vda5050/bridge.py) feeds it and sends what it returns.

The vehicle knows nothing of our leases, tasks or board, so the link does for it what a
heartbeat robot does itself (docs/robot-protocol.md):

* a `state` message becomes one heartbeat (`heartbeat()`): status, floor and waypoint from its
  last node, battery, load, the plan version of the order it reports; FINISHED `pick`/`drop`
  actions become `loaded`/`unloaded` events whose ids are made from the task and stop, so a
  state repeated any number of times, or read again after a restart of the bridge, applies each
  of them once; reaching a crossing's waiting node sends the `acquire`; leaving it after the
  grant is `resource_entered`, reaching the node beyond it `resource_released`;
* the heartbeat's board messages (`messages()`): a newer plan becomes the next order (after a
  `cancelOrder` if the vehicle is still busy with the previous one, and never while it is inside
  an elevator, door or corridor); a grant releases the order's horizon up to the next crossing by
  an order update; pause and resume are `startPause` and `stopPause`; return to dock an order to
  the dock. Every message is acked once dealt with, as a robot acks it.
"""

import logging
import uuid
from dataclasses import dataclass, field

from robots.router import Router, SiteMap
from vda5050.factsheet import factsheet_speed_max, order_problems
from vda5050.orders import (
    ALLOWED_DEVIATION_XY,
    EVENT_OF_ACTION,
    INSTANT_ACTIONS_FIELD,
    Crossing,
    Order,
    VehicleOptions,
    action_parse,
    order_build,
    order_wire,
)

logger = logging.getLogger("vda5050")

RUNNING = {"INITIALIZING", "RUNNING"}
# The errors by which a 2.0 vehicle refuses an order or an order update (its errorReferences
# name the orderId): what it was sent will not be driven.
REFUSALS = {"orderError", "orderUpdateError", "validationError", "noRouteError"}
# 2.0: a vehicle publishes its state on every event "or at the latest every 30 s".
STATE_INTERVAL = 30.0
# A gap longer than this between two states is a vehicle in trouble, not its interval.
OBSERVED_AT_MOST = 120.0
GONE = {"CONNECTIONBROKEN", "OFFLINE"}


@dataclass
class Outgoing:
    """What to publish to the vehicle: `topic` (order or instantActions) and its body."""

    topic: str
    body: dict


@dataclass
class Wanted:
    """The route the vehicle should be on: a plan's stops (or the dock, on return_to_dock)."""

    key: int  # grows with each new want
    plan_version: int
    stops: list[dict]


@dataclass
class Link:
    robot_id: int
    robot_code: str
    dock: str
    site_map: SiteMap
    router: Router
    options: VehicleOptions = field(default_factory=VehicleOptions)
    lifts_by_car: bool = False  # the building reports the cars (building.services)
    boot_id: str = field(default_factory=lambda: f"vda-{uuid.uuid4().hex[:16]}")
    seq: int = 0
    events: list[dict] = field(default_factory=list)  # not yet applied
    reported: set[str] = field(default_factory=set)  # ids of every event queued
    requests: list[dict] = field(default_factory=list)
    acks: list[str] = field(default_factory=list)
    handled: set[str] = field(default_factory=set)  # board message ids dealt with
    done: set[tuple[str, int]] = field(default_factory=set)  # (task, stop) loaded or unloaded
    completed: set[str] = field(default_factory=set)
    order: Order | None = None
    order_key: int = 0  # the Wanted.key the order was made for
    wanted: Wanted | None = None
    orders_made: int = 0
    cancel_sent_for: str | None = None  # the orderId a cancelOrder was sent for
    versions: dict[str, int] = field(default_factory=dict)  # orderId -> plan version
    last_state: dict | None = None
    held_requests: int = 0
    refused: set[str] = field(default_factory=set)  # orderIds the vehicle refused
    connection: str = ""  # its last `connection` message's connectionState
    observed_interval: float = 0.0  # the longest gap between two of its states
    factsheet: dict = field(default_factory=dict)  # its last `factsheet` message, if any
    factsheet_asked: bool = False
    cars_come: list[Crossing] = field(default_factory=list)  # late, after an alert

    def resume(self, plan: dict) -> None:
        """Start from the robot's current plan (the bridge started while it was out): the
        vehicle's order, unknown to this link, is cancelled and the plan ordered again."""
        self.wanted = Wanted(key=1, plan_version=plan["plan_version"], stops=plan["stops"])

    # --- state -> heartbeat ------------------------------------------------------------------

    def heartbeat(self, state: dict) -> dict:
        """The heartbeat this state message stands for (a body for HeartbeatSerializer)."""
        self.last_state = state
        self._refusals_seen(state)
        self._actions_seen(state)
        current = self._current(state)
        if current is not None:
            self._crossings_seen(current, state)
        self.seq += 1
        return {
            "boot_id": self.boot_id,
            "seq": self.seq,
            "state": self._state(state, current),
            "events": list(self.events),
            "acks": list(self.acks),
            "requests": list(self.requests),
        }

    def applied(self) -> None:
        """The heartbeat was applied: what it carried is done with."""
        self.events, self.requests, self.acks = [], [], []

    def drop_refused(self, paths: list[str]) -> bool:
        """Drop the events and requests a refusal names (as robots do); whether any was."""
        dropped = False
        for name, items in (("events", self.events), ("requests", self.requests)):
            bad = {int(p[len(name) + 1 :].split("]")[0]) for p in paths if p.startswith(f"{name}[")}
            for index in sorted(bad, reverse=True):
                if index < len(items):
                    logger.error("%s: dropping refused %s", self.robot_code, items.pop(index))
                    dropped = True
        return dropped

    @property
    def state_interval(self) -> float:
        """How long this vehicle may be silent while nothing happens: declared, else the
        longest it has been (within reason), and never less than 2.0's."""
        return self.options.state_interval or max(STATE_INTERVAL, self.observed_interval)

    def state_gap(self, seconds: float) -> None:
        """Two of its states came `seconds` apart, connected all along."""
        self.observed_interval = max(self.observed_interval, min(seconds, OBSERVED_AT_MOST))

    @property
    def connected(self) -> bool:
        return self.connection not in GONE

    # --- factsheet -----------------------------------------------------------------------------

    def factsheet_seen(self, factsheet: dict) -> None:
        self.factsheet = factsheet
        speed_max = factsheet_speed_max(factsheet)
        if speed_max is not None and speed_max < self.site_map.robot_speed:
            logger.warning(
                "%s: its top speed (%s m/s) is below the site's robot_speed (%s m/s): its ETAs "
                "will be late",
                self.robot_code,
                speed_max,
                self.site_map.robot_speed,
            )

    def factsheet_request(self) -> Outgoing | None:
        """factsheetRequest, once, to a vehicle whose factsheet we have not seen."""
        if self.factsheet or self.factsheet_asked:
            return None
        self.factsheet_asked = True
        return self.instant_actions("factsheetRequest")

    # --- held at a lift -----------------------------------------------------------------------

    def held_at_lift(self, now: float) -> list[Crossing]:
        """The lifts at whose lobby the vehicle has waited, granted, longer than the site allows
        for a car that does not come: each once. It stays held (base_end keeps the car's edge)."""
        state, order = self.last_state, self.order
        if state is None or order is None or state["orderId"] != order.order_id:
            return []
        late = []
        for crossing in order.crossings:
            waiting = crossing.car_seq is not None and crossing.granted and not crossing.car_here
            if not waiting or state["lastNodeSequenceId"] != crossing.wait_seq:
                continue
            if crossing.held_since is None:
                crossing.held_since = now
            too_long = now - crossing.held_since >= self.options.lift_wait_alert
            if too_long and not crossing.held_alerted:
                crossing.held_alerted = True
                late.append(crossing)
        return late

    def lift_cars_come(self) -> list[Crossing]:
        """The lifts whose car came after all, once the alert was raised: each once."""
        came, self.cars_come = self.cars_come, []
        return came

    def _refusals_seen(self, state: dict) -> None:
        """The vehicle refused our order: its tasks go back (task_failed, with its words)."""
        order = self.order
        if order is None or order.order_id in self.refused:
            return
        for error in state["errors"]:
            refs = {
                r["referenceKey"]: r["referenceValue"] for r in error.get("errorReferences", [])
            }
            refusal = error["errorType"] in REFUSALS or error["errorLevel"] == "FATAL"
            if refusal and refs.get("orderId") == order.order_id:
                self._order_refused(order, error)
                return

    def _order_refused(self, order: Order, error: dict) -> None:
        words = f"{error['errorType']}: {error.get('errorDescription', '')}".strip(": ")
        self._tasks_given_back(order, f"{self.robot_code} refused order {order.order_id}: {words}")

    def _tasks_given_back(self, order: Order, reason: str) -> None:
        """The order's tasks not done go back (task_failed, one reason: one operator alert)."""
        self.refused.add(order.order_id)
        reason = reason[:200]
        logger.error("%s", reason)
        for task, stop, _ in order.stop_actions.values():
            if (task, stop) not in self.done:
                self._event(
                    f"vda-{task}-refused-{order.order_id}", "task_failed", task=task, reason=reason
                )

    def _current(self, state: dict) -> Order | None:
        order = self.order
        return order if order is not None and state["orderId"] == order.order_id else None

    def _actions_seen(self, state: dict) -> None:
        for action in state["actionStates"]:
            parsed = action_parse(action["actionId"])
            if parsed is None:
                continue
            kind, task, stop = parsed
            if action["actionStatus"] in RUNNING | {"FINISHED"}:
                self._event(f"vda-{task}-{stop}-arrived", "arrived", task=task, stop=stop)
            if action["actionStatus"] == "FINISHED" and (task, stop) not in self.done:
                self.done.add((task, stop))
                self._event(f"vda-{task}-{stop}", EVENT_OF_ACTION[kind], task=task, stop=stop)
            if action["actionStatus"] == "FAILED" and self._failed_by_vehicle(action):
                reason = action.get("resultDescription") or f"{kind} failed"
                self._event(f"vda-{task}-{stop}-failed", "task_failed", task=task, reason=reason)
        if self.order is not None:
            for task in self.order.tasks_done(self.done):
                if task not in self.completed:
                    self.completed.add(task)
                    self._event(f"vda-{task}-completed", "task_completed", task=task)

    def _failed_by_vehicle(self, action: dict) -> bool:
        """A pick or drop of the order the vehicle drives now that failed, not one a cancelOrder
        of ours ended (the standard fails the actions a cancelled order had not started)."""
        order = self.order
        order_id = action["actionId"].split("/")[0]
        return order is not None and order_id == order.order_id != self.cancel_sent_for

    def _event(self, event_id: str, type: str, **fields) -> None:
        # Ids from what happened, not from a counter: the same fact always has the same id, so
        # the board applies it once however often the vehicle (or a restarted bridge) says it.
        # Queued once per run of the bridge all the same: states repeat it every second.
        if event_id not in self.reported:
            self.reported.add(event_id)
            self.events.append({"id": event_id, "type": type, **fields})

    def _crossings_seen(self, order: Order, state: dict) -> None:
        last, driving = state["lastNodeSequenceId"], state["driving"]
        for crossing in order.crossings:
            if not crossing.request_id and last >= crossing.wait_seq:
                crossing.request_id = f"q-{order.order_id}-{crossing.index}"
                request = {"id": crossing.request_id, "type": "acquire"}
                request["resource"] = crossing.resource
                if crossing.to_floor:
                    request["to_floor"] = crossing.to_floor
                self.requests.append(request)
            gone = last > crossing.wait_seq or (last == crossing.wait_seq and driving)
            if crossing.car_seq is not None:  # in a lift only once in the car
                gone = last >= crossing.car_seq
            if crossing.granted and not crossing.entered and gone:
                crossing.entered = True
                ident = f"r-{order.order_id}-{crossing.index}"
                self._event(f"{ident}-in", "resource_entered", resource=crossing.resource)
            if crossing.entered and not crossing.released and last >= crossing.exit_seq:
                crossing.released = True
                ident = f"r-{order.order_id}-{crossing.index}"
                self._event(f"{ident}-out", "resource_released", resource=crossing.resource)

    def _state(self, state: dict, current: Order | None) -> dict:
        waypoint = state["lastNodeId"] if state["lastNodeId"] in self.site_map.waypoints else None
        position = state.get("agvPosition") or {}
        if waypoint is not None:
            floor = self.site_map.waypoints[waypoint].floor
        else:
            floor = position.get("mapId") or self.site_map.waypoints[self.dock].floor
        fatal = [e for e in state["errors"] if e["errorLevel"] == "FATAL"]
        return {
            "status": self._status(state, current, fatal),
            "floor": floor,
            "waypoint": waypoint,
            "x": position.get("x"),
            "y": position.get("y"),
            "heading": position.get("theta"),
            "battery": round(state["batteryState"]["batteryCharge"] / 100, 4),
            "load": min(len(state.get("loads", [])), 32767),
            "plan_version": self.versions.get(state["orderId"], 0),
            "errors": [
                f"{e['errorType']}: {e.get('errorDescription', '')}".strip(": ")[:200]
                for e in fatal
            ][:50],
        }

    def _status(self, state: dict, current: Order | None, fatal: list) -> str:
        if fatal:
            return "error"
        if state.get("paused"):
            return "paused"
        for action in state["actionStates"]:
            parsed = action_parse(action["actionId"])
            if parsed and action["actionStatus"] in RUNNING:
                return "waiting_load" if parsed[0] == "pick" else "waiting_unload"
        crossings = current.crossings if current else []
        if any(c.inside for c in crossings):
            return "in_resource"
        last = state["lastNodeSequenceId"]
        held = [c for c in crossings if not c.granted or (c.car_seq and not c.car_here)]
        if any(c.request_id and last == c.wait_seq for c in held):
            return "waiting_resource"
        if state["driving"] or state["nodeStates"]:
            return "moving"
        return "charging" if state["batteryState"]["charging"] else "idle"

    # --- board messages -> orders and instant actions -------------------------------------------

    def messages(self, messages: list[dict]) -> list[Outgoing]:
        """Deal with the heartbeat's board messages; what to publish to the vehicle."""
        out: list[Outgoing] = []
        order_changed = False
        for message in messages:
            if message["id"] in self.handled:
                continue
            self.handled.add(message["id"])
            kind = message["type"]
            if kind == "plan":
                self._plan(message)
            elif kind == "resource_grant":
                order_changed |= self._grant(message)
            elif kind == "elevator_at_floor":
                order_changed |= self._car(message)
            elif kind == "action":
                out += self._action(message)
            self.acks.append(message["id"])
        out += self._reconcile(order_changed)
        return out

    def _plan(self, message: dict) -> None:
        """Acked at once, as a robot acks a plan it will apply at its next waypoint: the
        vehicle may be in an elevator now, longer than the site's ack timeout."""
        wanted = self.wanted
        if wanted is not None and message["plan_version"] <= wanted.plan_version:
            return  # an older plan: ack, never follow
        self.wanted = Wanted(
            key=(wanted.key + 1) if wanted else 1,
            plan_version=message["plan_version"],
            stops=message["stops"],
        )

    def _grant(self, message: dict) -> bool:
        order = self.order
        for crossing in order.crossings if order else []:
            if crossing.request_id and crossing.request_id == message["request"]:
                crossing.granted = True
                return True
        # A grant for a route the vehicle no longer takes: give it back at once.
        self._request("release", message["resource"])
        return False

    def _car(self, message: dict) -> bool:
        """The car of a lift we hold stopped, doors open: at the vehicle's floor it may get
        in; at the destination with the vehicle in it, out."""
        for crossing in self.order.crossings if self.order else []:
            if crossing.resource != message["resource"] or crossing.car_seq is None:
                continue
            if not crossing.granted or crossing.released:
                continue
            if not crossing.entered and message["floor"] == crossing.from_floor:
                crossing.car_here = True
                if crossing.held_alerted:
                    self.cars_come.append(crossing)
                return True
            if crossing.entered and message["floor"] == crossing.to_floor:
                crossing.car_there = True
                return True
        return False

    def _action(self, message: dict) -> list[Outgoing]:
        action = message["action"]
        if action == "return_to_dock":
            version = self.wanted.plan_version if self.wanted else 0
            key = (self.wanted.key + 1) if self.wanted else 1
            dock = [{"action": "dock", "waypoint": self.dock}]
            self.wanted = Wanted(key=key, plan_version=version, stops=dock)
            return []
        kind = {"pause": "startPause", "resume": "stopPause"}.get(action)
        return [self._instant(kind)] if kind else []

    def _instant(self, kind: str) -> Outgoing:
        """One instant action and a stateRequest after it: its outcome is wanted at once."""
        return self.instant_actions(kind, "stateRequest")

    def instant_actions(self, *kinds: str) -> Outgoing:
        actions = [
            {
                "actionType": kind,
                "actionId": f"{kind}-{uuid.uuid4().hex[:12]}",
                "blockingType": "NONE",
            }
            for kind in kinds
        ]
        for action in actions:
            if action["actionType"] in ("startPause", "stopPause", "cancelOrder"):
                action["blockingType"] = "HARD"
        name = "instantActions" if INSTANT_ACTIONS_FIELD in self.options.quirks else "actions"
        return Outgoing("instantActions", {name: actions})

    def _request(self, type: str, resource: str) -> None:
        self.held_requests += 1
        ident = f"q-{self.boot_id[4:12]}-{type}-{self.held_requests}"
        self.requests.append({"id": ident, "type": type, "resource": resource})

    def _reconcile(self, order_changed: bool) -> list[Outgoing]:
        """Bring the vehicle's order to what is wanted, as far as it can be now."""
        state, order, wanted = self.last_state, self.order, self.wanted
        if state is None or wanted is None:
            return []
        if order is not None and self.order_key == wanted.key:
            return self._update(order) if order_changed else []
        if order is not None and any(c.inside for c in order.crossings):
            return []  # never switch routes inside an elevator, door or corridor
        if _loading(state):
            return []  # nor while the staff load or unload it: the new route starts after
        if state["nodeStates"]:  # still on its previous order: cancel it first
            if self.cancel_sent_for == state["orderId"]:
                return []
            self.cancel_sent_for = state["orderId"]
            return [self._instant("cancelOrder")]
        return self._new_order(state, wanted)

    def _new_order(self, state: dict, wanted: Wanted) -> list[Outgoing]:
        self._release_unused()
        start = state["lastNodeId"]
        if start not in self.site_map.waypoints:
            logger.error("%s: last node %r is not on the map", self.robot_code, start)
            return []
        here = self._away_from(start, state)
        self.orders_made += 1
        order_id = f"{self.robot_code}-{self.boot_id[4:12]}-{self.orders_made}"
        self.order_key = wanted.key
        stops = [s for s in wanted.stops if (s.get("task"), s.get("stop")) not in self.done]
        self.order = order_build(
            site_map=self.site_map,
            router=self.router,
            order_id=order_id,
            plan_version=wanted.plan_version,
            start=start,
            stops=stops,
            options=self.options,
            here=here,
            lifts_by_car=self.lifts_by_car,
        )
        self.versions[order_id] = wanted.plan_version
        problems = order_problems(self.factsheet, self.order)
        if problems:  # refused here: never sent, its tasks back as if the vehicle had refused
            words = "; ".join(problems)
            self._tasks_given_back(
                self.order, f"{self.robot_code}: order {order_id} not sent: {words}"
            )
            return []
        for waypoint in self.order.unreachable:
            logger.error("%s: no route to %s", self.robot_code, waypoint)
        logger.info("%s: order %s (plan %s)", self.robot_code, order_id, wanted.plan_version)
        return [
            Outgoing("order", order_wire(self.order, self.site_map)),
            self.instant_actions("stateRequest"),
        ]

    def _away_from(self, start: str, state: dict) -> tuple[float, float, str] | None:
        """Where the vehicle stands if that is not its last node (a cancelOrder stopped it
        between two): a new order must start there (2.0 §6.6.3.1)."""
        position = state.get("agvPosition")
        if not position:
            return None
        node = self.site_map.waypoints[start]
        off = ((position["x"] - node.x) ** 2 + (position["y"] - node.y) ** 2) ** 0.5
        if off <= ALLOWED_DEVIATION_XY:
            return None
        return (position["x"], position["y"], position["mapId"])

    def _release_unused(self) -> None:
        """Leases asked for on the old route and not entered are given back."""
        for crossing in self.order.crossings if self.order else []:
            if crossing.request_id and not crossing.entered:
                self._request("release", crossing.resource)

    def _update(self, order: Order) -> list[Outgoing]:
        """An order update releasing the horizon up to the next crossing not granted."""
        previous, order.released_until = order.released_until, order.base_end()
        if order.released_until == previous:
            return []
        order.update_id += 1
        update = order_wire(order, self.site_map, from_seq=previous)
        return [Outgoing("order", update), self.instant_actions("stateRequest")]


def _loading(state: dict) -> bool:
    """A pick or drop of ours is under way (its order is not done even with no nodes left)."""
    return any(
        action["actionStatus"] in RUNNING | {"PAUSED"} and action_parse(action["actionId"])
        for action in state["actionStates"]
    )
