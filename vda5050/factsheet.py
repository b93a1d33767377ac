"""A vehicle's `factsheet` (VDA 5050 2.0 §6.x): what it says it can do, read before an order is
sent. Pure Python, as orders.py.

Only what the vehicle lists is held against it: a factsheet without `protocolFeatures.
agvActions` (vda-5050-lib's virtual vehicle publishes only the header) checks nothing. Where
the list is there, every action of an order must be in it, and every parameter the vehicle
lists as not optional must be given.
"""

from vda5050.orders import Order


def factsheet_actions(factsheet: dict) -> dict[str, dict] | None:
    """The actions the vehicle lists, by actionType; None if it lists none."""
    listed = (factsheet.get("protocolFeatures") or {}).get("agvActions")
    if not listed:
        return None
    return {action["actionType"]: action for action in listed}


def factsheet_speed_max(factsheet: dict) -> float | None:
    return (factsheet.get("physicalParameters") or {}).get("speedMax")


def order_problems(factsheet: dict, order: Order) -> list[str]:
    """What in the order the vehicle's factsheet says it cannot do, in words; empty if none."""
    listed = factsheet_actions(factsheet)
    if listed is None:
        return []
    problems: list[str] = []
    for node in order.nodes:
        for action in node.actions:
            problem = _action_problem(listed, action)
            if problem and problem not in problems:
                problems.append(problem)
    return problems


def _action_problem(listed: dict[str, dict], action: dict) -> str:
    kind = action["actionType"]
    known = listed.get(kind)
    if known is None:
        return f"its factsheet lists no action {kind!r}"
    scopes = known.get("actionScopes")
    if scopes and "NODE" not in scopes:
        return f"its factsheet allows {kind!r} only as {'/'.join(scopes)}, not on a node"
    given = {parameter["key"] for parameter in action.get("actionParameters", [])}
    for parameter in known.get("actionParameters") or []:
        if not parameter.get("isOptional", False) and parameter["key"] not in given:
            return f"its factsheet says {kind!r} needs the parameter {parameter['key']!r}"
    return ""
