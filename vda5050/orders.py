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
"""

from dataclasses import dataclass, field

from robots.router import Router, SiteMap, edge_index

PICK, DROP = "pick", "drop"
ACTION_OF_STOP = {"pickup": PICK, "dropoff": DROP}
EVENT_OF_ACTION = {PICK: "loaded", DROP: "unloaded"}


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

    @property
    def inside(self) -> bool:
        return self.entered and not self.released


@dataclass(frozen=True)
class OrderNode:
    seq: int
    waypoint: str
    actions: tuple[dict, ...] = ()


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
) -> Order:
    """The order driving from `start` through `stops` (a plan's stops, those done left out)."""
    nodes = [OrderNode(0, start)]
    stop_actions: dict[str, tuple[str, int, str]] = {}
    unreachable = []
    for stop in stops:
        path = router.leg(nodes[-1].waypoint, stop["waypoint"]).path
        if not path:
            unreachable.append(stop["waypoint"])
            continue
        for waypoint in path[1:]:
            nodes.append(OrderNode(nodes[-1].seq + 2, waypoint))
        kind = ACTION_OF_STOP.get(stop["action"])
        if kind is not None:
            ident = action_id(order_id, kind, stop["task"], stop["stop"])
            stop_actions[ident] = (stop["task"], stop["stop"], kind)
            last = nodes[-1]
            nodes[-1] = OrderNode(last.seq, last.waypoint, (*last.actions, _action(ident, kind)))
    edges = _edges(site_map, nodes)
    order = Order(
        order_id=order_id,
        plan_version=plan_version,
        nodes=nodes,
        edges=edges,
        crossings=_crossings(site_map, edges),
        stop_actions=stop_actions,
        unreachable=unreachable,
    )
    order.released_until = order.base_end()
    return order


def _action(ident: str, kind: str) -> dict:
    # HARD: the vehicle neither drives nor starts another action until the staff are done.
    return {"actionType": kind, "actionId": ident, "blockingType": "HARD", "actionParameters": []}


def _edges(site_map: SiteMap, nodes: list[OrderNode]) -> list[OrderEdge]:
    index = edge_index(site_map)
    edges = []
    for a, b in zip(nodes, nodes[1:], strict=False):
        edge = index.get((a.waypoint, b.waypoint))
        if edge is not None:
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
    waypoint = site_map.waypoints[node.waypoint]
    return {
        "nodeId": node.waypoint,
        "sequenceId": node.seq,
        "released": node.seq <= released,
        "nodePosition": {"x": waypoint.x, "y": waypoint.y, "mapId": waypoint.floor},
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
