"""What a draft changes against the live map: pure functions of two site documents.

The draft may be invalid while it is edited, so everything here reads it defensively and
skips what it cannot make sense of (validation names those problems).
"""

from dataclasses import dataclass, field

from robots.router import file_edge_ends

STATION = "station"


@dataclass(frozen=True)
class Change:
    what: str  # floor, waypoint, edge, station, resource
    how: str  # added, removed, moved, renamed, changed
    code: str
    detail: str = ""

    def wire(self) -> dict:
        return {"what": self.what, "how": self.how, "code": self.code, "detail": self.detail}


@dataclass
class MapDiff:
    changes: list[Change] = field(default_factory=list)
    removed_waypoints: set[str] = field(default_factory=set)
    removed_edges: set[tuple[str, str]] = field(default_factory=set)  # both directions
    removed_resources: set[str] = field(default_factory=set)
    removed_stations: set[str] = field(default_factory=set)

    @property
    def is_empty(self) -> bool:
        return not self.changes


def map_diff(live: dict, draft: dict) -> MapDiff:
    diff = MapDiff()
    _floors(diff, _floors_of(live), _floors_of(draft))
    old_wps, new_wps = _waypoints_of(live), _waypoints_of(draft)
    _waypoints(diff, old_wps, new_wps)
    _edges(diff, _edges_of(live), _edges_of(draft))
    _resources(diff, _by_code(_list(live, "resources")), _by_code(_list(draft, "resources")))
    return diff


# --- Reading a document that may be invalid -----------------------------------------------------


def _list(mapping, key: str) -> list:
    value = mapping.get(key) if isinstance(mapping, dict) else None
    return value if isinstance(value, list) else []


def _by_code(items: list) -> dict[str, dict]:
    found = {}
    for item in items:
        if isinstance(item, dict) and isinstance(item.get("code"), str):
            found.setdefault(item["code"], item)
    return found


def _floors_of(document: dict) -> dict[str, dict]:
    return _by_code(_list(document, "floors"))


def _waypoints_of(document: dict) -> dict[str, dict]:
    found = {}
    for floor_code, floor in _floors_of(document).items():
        for code, wp in _by_code(_list(floor, "waypoints")).items():
            found.setdefault(code, {**wp, "floor": floor_code})
    return found


def _edges_of(document: dict) -> dict[tuple[str, str], dict]:
    """Edges by (from, to); a two-way edge under both directions."""
    found = {}
    for floor in _floors_of(document).values():
        for raw in _list(floor, "edges"):
            try:
                source, target, length, oneway = file_edge_ends(raw)
            except (KeyError, IndexError, TypeError, AttributeError):
                continue
            if not (isinstance(source, str) and isinstance(target, str)):
                continue
            edge = {"from": source, "to": target, "length": length, "oneway": oneway}
            found.setdefault((source, target), edge)
            if not oneway:
                found.setdefault((target, source), edge)
    return found


# --- Comparing ---------------------------------------------------------------------------------


def _floors(diff: MapDiff, old: dict, new: dict) -> None:
    for code in sorted(new.keys() - old.keys()):
        diff.changes.append(Change("floor", "added", code, f"level {new[code].get('level')}"))
    for code in sorted(old.keys() - new.keys()):
        diff.changes.append(Change("floor", "removed", code))
    for code in sorted(old.keys() & new.keys()):
        before, after = old[code], new[code]
        if before.get("name", "") != after.get("name", ""):
            detail = f"{before.get('name', '')!r} → {after.get('name', '')!r}"
            diff.changes.append(Change("floor", "renamed", code, detail))
        _names_changes(diff, "floor", code, before, after)
        if before.get("level") != after.get("level"):
            detail = f"level {before.get('level')} → {after.get('level')}"
            diff.changes.append(Change("floor", "changed", code, detail))


def _waypoints(diff: MapDiff, old: dict[str, dict], new: dict[str, dict]) -> None:
    added, removed = new.keys() - old.keys(), old.keys() - new.keys()
    recoded = _recoded(old, new, added, removed)
    for before, after in sorted(recoded.items()):
        diff.changes.append(Change("waypoint", "renamed", after, f"code was '{before}'"))
    diff.removed_waypoints = set(removed)  # a new code is a new waypoint to robots and tasks
    for code in sorted(added - set(recoded.values())):
        wp = new[code]
        diff.changes.append(Change("waypoint", "added", code, _where(wp)))
    for code in sorted(removed - set(recoded)):
        diff.changes.append(Change("waypoint", "removed", code, _where(old[code])))
    for code in sorted(old.keys() & new.keys()):
        _waypoint_changes(diff, code, old[code], new[code])
    for code in sorted(removed):
        if old[code].get("kind") == STATION:
            diff.removed_stations.add(code)
    _station_changes(diff, old, new)


def _recoded(old: dict, new: dict, added: set, removed: set) -> dict[str, str]:
    """Removed waypoints with an added one of the same floor and place: a code changed."""
    spots = {_spot(new[code]): code for code in sorted(added)}
    recoded = {}
    for code in sorted(removed):
        match = spots.pop(_spot(old[code]), None)
        if match is not None:
            recoded[code] = match
    return recoded


def _spot(wp: dict) -> tuple:
    """Where a waypoint is: 40, 40.0 and 4e1 are one place (YAML, JSON and the editor write
    numbers differently); an invalid draft may hold anything as x or y."""
    return wp["floor"], _comparable(wp.get("x")), _comparable(wp.get("y"))


def _comparable(value):
    """A value as compared: numbers as numbers, anything else as written."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    return repr(value)


def _names_changes(diff: MapDiff, what: str, code: str, before: dict, after: dict) -> None:
    """A name in one language given, changed or taken away."""
    old, new = before.get("names") or {}, after.get("names") or {}
    for language in sorted(old.keys() | new.keys()):
        if old.get(language) != new.get(language):
            detail = f"{language}: {old.get(language, '')!r} → {new.get(language, '')!r}"
            diff.changes.append(Change(what, "renamed", code, detail))


def _where(wp: dict) -> str:
    kind = wp.get("kind", "plain")
    return f"{kind} on {wp['floor']} at ({wp.get('x')}, {wp.get('y')})"


def _waypoint_changes(diff: MapDiff, code: str, before: dict, after: dict) -> None:
    if _spot(before) != _spot(after):
        detail = f"{_where(before)} → ({after.get('x')}, {after.get('y')}) on {after['floor']}"
        diff.changes.append(Change("waypoint", "moved", code, detail))
    if before.get("name", "") != after.get("name", ""):
        detail = f"{before.get('name', '')!r} → {after.get('name', '')!r}"
        diff.changes.append(Change("waypoint", "renamed", code, detail))
    _names_changes(diff, "waypoint", code, before, after)
    if before.get("kind", "plain") != after.get("kind", "plain"):
        detail = f"{before.get('kind', 'plain')} → {after.get('kind', 'plain')}"
        diff.changes.append(Change("waypoint", "changed", code, detail))


def _station_changes(diff: MapDiff, old: dict, new: dict) -> None:
    was = {code for code, wp in old.items() if wp.get("kind") == STATION}
    now = {code for code, wp in new.items() if wp.get("kind") == STATION}
    for code in sorted(now - was):
        diff.changes.append(Change(STATION, "added", code, new[code].get("name", "")))
    for code in sorted(was - now):
        diff.changes.append(Change(STATION, "removed", code, old[code].get("name", "")))
        diff.removed_stations.add(code)


def _edges(diff: MapDiff, old: dict, new: dict) -> None:
    for key in sorted(old.keys() - new.keys()):
        diff.removed_edges.add(key)
    for edge, how in [*_unique(old, new.keys(), "removed"), *_unique(new, old.keys(), "added")]:
        arrow = "→" if edge["oneway"] else "–"
        code = f"{edge['from']} {arrow} {edge['to']}"
        diff.changes.append(Change("edge", how, code))
    for key in sorted(old.keys() & new.keys()):
        before, after = old[key], new[key]
        if key == (before["from"], before["to"]) and _shape(before) != _shape(after):
            detail = f"{_shape(before)} → {_shape(after)}"
            diff.changes.append(Change("edge", "changed", f"{key[0]} – {key[1]}", detail))


def _unique(edges: dict, other: set, how: str):
    """Each edge of `edges` missing from `other`, once (not once per direction)."""
    seen = set()
    for key in sorted(edges.keys() - other):
        edge = edges[key]
        if id(edge) not in seen:
            seen.add(id(edge))
            yield edge, how


def _shape(edge: dict) -> str:
    length = "straight" if edge["length"] is None else f"{_number(edge['length'])} m"
    return f"{length}, {'one-way' if edge['oneway'] else 'two-way'}"


def _resources(diff: MapDiff, old: dict[str, dict], new: dict[str, dict]) -> None:
    for code in sorted(new.keys() - old.keys()):
        diff.changes.append(Change("resource", "added", code, new[code].get("kind", "")))
    for code in sorted(old.keys() - new.keys()):
        diff.changes.append(Change("resource", "removed", code, old[code].get("kind", "")))
        diff.removed_resources.add(code)
    for code in sorted(old.keys() & new.keys()):
        changed = [
            key
            for key in sorted(old[code].keys() | new[code].keys())
            if _resource_value(key, old[code].get(key)) != _resource_value(key, new[code].get(key))
        ]
        if changed:
            diff.changes.append(Change("resource", "changed", code, ", ".join(changed)))


# A resource's lists whose order means nothing: where robots wait, and the edges it guards.
UNORDERED = {"waiting", "guards"}


def _resource_value(key: str, value):
    if isinstance(value, list) and key in UNORDERED:
        return frozenset(_resource_value("", item) for item in value)
    if isinstance(value, list):
        return tuple(_resource_value("", item) for item in value)
    if isinstance(value, dict):
        return frozenset((name, _resource_value("", item)) for name, item in value.items())
    return _comparable(value)


def _number(value):
    """A length as people write it: 12, not 12.0."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value
