"""Our plans as VDA 5050 orders: pure Python on the site map (robots.router), no database.

A plan's stops become one order: the route from the vehicle's last node through every stop,
node by node (nodeId = waypoint code, mapId = floor code), with a `pick` or `drop` action at
each task stop. Nodes take the even sequenceIds (0, 2, 4, ...) and the edges between them the
odd ones, as the standard numbers them.

Shared resources keep our lease rules. Each elevator ride and each passage through a door or
corridor is a Crossing: the node where the vehicle waits for it ends the released part of the
order (the base); everything beyond stays in the horizon (`released: false`) until the lease
is granted, when an order update (orderUpdateId + 1) releases up to the next crossing not yet
granted. That is how VDA 5050 lets master control hold a vehicle before a shared zone.

A lift the building drives is ridden by the car, not by the lease: between the two lobbies the
order has a node in the car (`<lift>-CAR`, on the lobby's floor and place). The edge into the
car is released only once the building reports the car at the vehicle's floor with its doors
open (`elevator_at_floor`), the ride out of it only once the car reports the destination.
"""

from dataclasses import dataclass, field

from robots.router import Router, SiteMap, edge_index

PICK, DROP = "pick", "drop"
ACTION_OF_STOP = {"pickup": PICK, "dropoff": DROP}
EVENT_OF_ACTION = {PICK: "loaded", DROP: "unloaded"}
# 2.0 lists stationType and loadType for pick and drop and leaves their values to the vehicle:
# a station is a hand-over point at floor level, and what is handed over is a tote. A site
# whose vehicle expects other values says so (the robot's `vda5050.pick` / `.drop`).
DEFAULT_PARAMETERS = {
    PICK: {"stationType": "floor", "loadType": "tote"},
    DROP: {"stationType": "floor", "loadType": "tote"},
}
# How far from a node's position the vehicle may be and still count as on it (2.0 §6.6.3.1:
# the first node of a new order is where the vehicle stands, within this range).
ALLOWED_DEVIATION_XY = 0.5
# How long a vehicle may wait at a lift it was granted, for a car that does not come, before
# the operators are told (the robot's `vda5050.lift_wait_alert` in the site file).
LIFT_WAIT_ALERT = 120.0
INSTANT_ACTIONS_FIELD = "instant_actions_field"
INIT_POSITION_AFTER_LIFT = "init_position_after_lift"


@dataclass(frozen=True)
class VehicleOptions:
    """The site file's `vda5050` mapping of one robot (robots.sitefile.VDA5050_FIELDS)."""

    pick: dict = field(default_factory=dict)
    drop: dict = field(default_factory=dict)
    stations: dict = field(default_factory=dict)
    state_interval: float | None = None
    lift_wait_alert: float = LIFT_WAIT_ALERT
    quirks: frozenset[str] = frozenset()

    @classmethod
    def from_site(cls, data: dict) -> "VehicleOptions":
        known = {k: v for k, v in data.items() if k in ("pick", "drop", "stations")}
        return cls(
            **known,
            state_interval=data.get("state_interval"),
            lift_wait_alert=data.get("lift_wait_alert", LIFT_WAIT_ALERT),
            quirks=frozenset(data.get("quirks", ())),
        )

    def parameters(self, kind: str, waypoint: str) -> list[dict]:
        """The actionParameters of a pick or drop at `waypoint`: the station's, else the
        vehicle's, else the defaults, key by key."""
        station = self.stations.get(waypoint, {}).get(kind, {})
        values = {**DEFAULT_PARAMETERS[kind], **getattr(self, kind), **station}
        return [{"key": key, "value": value} for key, value in values.items()]


@dataclass
class Crossing:
    """One use of a shared resource on the order's route."""

    index: int
    resource: str
    wait_seq: int  # the node where the vehicle waits for the grant (end of the base until then)
    exit_seq: int  # the first node beyond the resource: reached means released
    to_floor: str | None  # elevators: the floor of the exit node
    request_id: str = ""  # our acquire request, once sent
    granted: bool = False
    entered: bool = False
    released: bool = False
    car_seq: int | None = None  # a lift ridden by the car: the node in the car
    from_floor: str | None = None  # the floor of the waiting node (lifts)
    car_here: bool = False  # the car reported at from_floor, doors open
    car_there: bool = False  # the car reported at to_floor with the vehicle in it
    held_since: float | None = None  # the bridge's clock: when it began waiting for the car
    held_alerted: bool = False

    @property
    def inside(self) -> bool:
        return self.entered and not self.released


@dataclass(frozen=True)
class OrderNode:
    seq: int
    waypoint: str  # a waypoint code, or a place of the vehicle's own (`position` given)
    actions: tuple[dict, ...] = ()
    position: tuple[float, float, str] | None = None  # x, y, mapId of a node off the map
    car: str = ""  # the lift whose car this node is in


@dataclass(frozen=True)
class OrderEdge:
    seq: int
    start: str
    end: str
    length: float
    resource: str | None


@dataclass
class Order:
    order_id: str
    plan_version: int
    nodes: list[OrderNode]
    edges: list[OrderEdge]
    crossings: list[Crossing]
    stop_actions: dict[str, tuple[str, int, str]]  # actionId -> (task, stop, pick or drop)
    update_id: int = 0
    released_until: int = 0  # the base's last node
    unreachable: list[str] = field(default_factory=list)  # stops' waypoints with no route

    def base_end(self) -> int:
        """The last node to release now: the waiting node of the first crossing not granted."""
        for crossing in self.crossings:
            if not crossing.granted:
                return crossing.wait_seq
            if crossing.car_seq is not None and not crossing.car_here:
                return crossing.wait_seq
            if crossing.car_seq is not None and not crossing.car_there:
                return crossing.car_seq
        return self.nodes[-1].seq

    def tasks_done(self, done: set[tuple[str, int]]) -> list[str]:
        """Tasks of this order whose every stop in it is done."""
        stops: dict[str, list[tuple[str, int]]] = {}
        for task, stop, _ in self.stop_actions.values():
            stops.setdefault(task, []).append((task, stop))
        return [task for task, keys in stops.items() if all(key in done for key in keys)]


def action_id(order_id: str, kind: str, task: str, stop: int) -> str:
    return f"{order_id}/{kind}/{task}/{stop}"


def action_parse(value: str) -> tuple[str, str, int] | None:
    """(kind, task, stop) of an action id this bridge made, else None."""
    parts = value.split("/")
    if len(parts) != 4 or parts[1] not in EVENT_OF_ACTION or not parts[3].isdigit():
        return None
    return parts[1], parts[2], int(parts[3])


def order_build(
    *,
    site_map: SiteMap,
    router: Router,
    order_id: str,
    plan_version: int,
    start: str,
    stops: list[dict],
    options: VehicleOptions | None = None,
    here: tuple[float, float, str] | None = None,
    lifts_by_car: bool = False,
) -> Order:
    """The order driving from `start` through `stops` (a plan's stops, those done left out).
    `here`: where the vehicle stands when that is not `start` (stopped between two nodes): the
    order's first node is then that place, and it drives back to `start` first.
    `lifts_by_car`: the building drives the lifts and reports their cars (a node in the car)."""
    options = options or VehicleOptions()
    nodes = [OrderNode(0, start)]
    if here is not None:
        nodes = [OrderNode(0, f"{order_id}/here", position=here), OrderNode(2, start)]
    stop_actions: dict[str, tuple[str, int, str]] = {}
    unreachable = []
    index = edge_index(site_map)
    for stop in stops:
        path = router.leg(nodes[-1].waypoint, stop["waypoint"]).path
        if not path:
            unreachable.append(stop["waypoint"])
            continue
        for waypoint in path[1:]:
            car = _car_node(site_map, index, nodes[-1], waypoint) if lifts_by_car else None
            if car is not None:
                nodes.append(car)
            nodes.append(OrderNode(nodes[-1].seq + 2, waypoint))
        kind = ACTION_OF_STOP.get(stop["action"])
        if kind is not None:
            ident = action_id(order_id, kind, stop["task"], stop["stop"])
            stop_actions[ident] = (stop["task"], stop["stop"], kind)
            last = nodes[-1]
            action = _action(ident, kind, options.parameters(kind, last.waypoint))
            nodes[-1] = OrderNode(last.seq, last.waypoint, (*last.actions, action))
        if stop["action"] == "dock":
            break  # a robot waits at a dock stop for its next plan (a refuge: the all-clear's)
    edges = _edges(site_map, nodes)
    crossings = _crossings(site_map, edges)
    for crossing in crossings:
        if nodes[crossing.wait_seq // 2 + 1].car:
            crossing.car_seq = crossing.wait_seq + 2
            crossing.from_floor = site_map.waypoints[nodes[crossing.wait_seq // 2].waypoint].floor
    if INIT_POSITION_AFTER_LIFT in options.quirks:
        _init_positions(site_map, order_id, nodes, crossings)
    order = Order(
        order_id=order_id,
        plan_version=plan_version,
        nodes=nodes,
        edges=edges,
        crossings=crossings,
        stop_actions=stop_actions,
        unreachable=unreachable,
    )
    order.released_until = order.base_end()
    return order


def _car_node(site_map: SiteMap, index: dict, last: OrderNode, waypoint: str) -> OrderNode | None:
    """The node in the car between two lobbies of a lift, else None."""
    if last.position is not None or (last.waypoint, waypoint) in index:
        return None
    lift = elevator_between(site_map, last.waypoint, waypoint)
    lobby = site_map.waypoints[last.waypoint]
    return OrderNode(
        last.seq + 2, f"{lift}-CAR", position=(lobby.x, lobby.y, lobby.floor), car=lift
    )


def _action(ident: str, kind: str, parameters: list[dict]) -> dict:
    # HARD: the vehicle neither drives nor starts another action until the staff are done.
    return {
        "actionType": kind,
        "actionId": ident,
        "blockingType": "HARD",
        "actionParameters": parameters,
    }


def _init_positions(
    site_map: SiteMap, order_id: str, nodes: list[OrderNode], crossings: list[Crossing]
) -> None:
    """For a vehicle that keeps its map after a lift ride: tell it where it came out."""
    for crossing in crossings:
        if crossing.to_floor is None:
            continue
        index = crossing.exit_seq // 2
        node = nodes[index]
        waypoint = site_map.waypoints[node.waypoint]
        values = {
            "x": waypoint.x,
            "y": waypoint.y,
            "theta": 0.0,
            "mapId": waypoint.floor,
            "lastNodeId": node.waypoint,
            "lastNodeSequenceId": node.seq,
        }
        action = {
            "actionType": "initPosition",
            "actionId": f"{order_id}/initPosition/{node.seq}",
            "blockingType": "HARD",
            "actionParameters": [{"key": k, "value": v} for k, v in values.items()],
        }
        nodes[index] = OrderNode(node.seq, node.waypoint, (action, *node.actions))


def _edges(site_map: SiteMap, nodes: list[OrderNode]) -> list[OrderEdge]:
    index = edge_index(site_map)
    edges = []
    for a, b in zip(nodes, nodes[1:], strict=False):
        edge = index.get((a.waypoint, b.waypoint))
        if a.car or b.car:  # into the lift's car, or out of it
            edges.append(OrderEdge(a.seq + 1, a.waypoint, b.waypoint, 0.0, a.car or b.car))
        elif a.position is not None:  # from where the vehicle stopped back to its last node
            edges.append(OrderEdge(a.seq + 1, a.waypoint, b.waypoint, 0.0, None))
        elif edge is not None:
            edges.append(OrderEdge(a.seq + 1, a.waypoint, b.waypoint, edge.length, edge.guarded_by))
        else:  # no floor edge: an elevator ride between two of its lobbies
            elevator = elevator_between(site_map, a.waypoint, b.waypoint)
            edges.append(OrderEdge(a.seq + 1, a.waypoint, b.waypoint, 0.0, elevator))
    return edges


def _crossings(site_map: SiteMap, edges: list[OrderEdge]) -> list[Crossing]:
    """Consecutive edges guarded by one resource are one passage (a corridor of two edges)."""
    crossings: list[Crossing] = []
    previous = None
    for edge in edges:
        if edge.resource is None:
            previous = None
            continue
        if previous is not None and previous.resource == edge.resource:
            previous.exit_seq = edge.seq + 1
        else:
            previous = Crossing(
                index=len(crossings),
                resource=edge.resource,
                wait_seq=edge.seq - 1,
                exit_seq=edge.seq + 1,
                to_floor=None,
            )
            crossings.append(previous)
    nodes_by_seq = {edge.seq + 1: edge.end for edge in edges}
    for crossing in crossings:
        if site_map.resources[crossing.resource].is_elevator:
            crossing.to_floor = site_map.waypoints[nodes_by_seq[crossing.exit_seq]].floor
    return crossings


def elevator_between(site_map: SiteMap, a: str, b: str) -> str:
    for code, stops in site_map.elevator_stops.items():
        if a in stops.values() and b in stops.values():
            return code
    raise LookupError(f"no edge and no elevator between {a} and {b}")


# --- On the wire --------------------------------------------------------------------------------


def order_wire(order: Order, site_map: SiteMap, *, from_seq: int = 0) -> dict:
    """The order's nodes and edges from `from_seq` on (an update starts at the old base's end),
    each released up to order.released_until. The caller adds the header."""
    released = order.released_until
    return {
        "orderId": order.order_id,
        "orderUpdateId": order.update_id,
        "nodes": [
            _node_wire(node, site_map, released) for node in order.nodes if node.seq >= from_seq
        ],
        "edges": [
            _edge_wire(edge, site_map, released) for edge in order.edges if edge.seq > from_seq
        ],
    }


def _node_wire(node: OrderNode, site_map: SiteMap, released: int) -> dict:
    if node.position is not None:
        x, y, map_id = node.position
    else:
        waypoint = site_map.waypoints[node.waypoint]
        x, y, map_id = waypoint.x, waypoint.y, waypoint.floor
    position = {"x": x, "y": y, "mapId": map_id, "allowedDeviationXy": ALLOWED_DEVIATION_XY}
    return {
        "nodeId": node.waypoint,
        "sequenceId": node.seq,
        "released": node.seq <= released,
        "nodePosition": position,
        "actions": list(node.actions),
    }


def _edge_wire(edge: OrderEdge, site_map: SiteMap, released: int) -> dict:
    wire = {
        "edgeId": f"{edge.start}>{edge.end}",
        "sequenceId": edge.seq,
        "released": edge.seq < released,
        "startNodeId": edge.start,
        "endNodeId": edge.end,
        "actions": [],
    }
    if edge.resource:
        wire["edgeDescription"] = edge.resource
    if edge.length:
        wire["length"] = edge.length
    return wire
