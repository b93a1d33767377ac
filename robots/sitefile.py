"""Site description files (robot-protocol.md, "Site description file"): read, validate, load.

A file is validated as a whole first, collecting every problem; only a valid file is written,
in one transaction, upserting rows by code so that unchanged things keep their primary keys.
"""

import difflib
import json
import math
import re
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from pathlib import Path

import yaml
from django.db import models, transaction
from django.db.models import ProtectedError, RestrictedError
from django.utils import timezone

from robots.choices import ResourceKind, RobotProtocol, VdaQuirk, WaypointKind
from robots.models import Edge, Floor, Resource, ResourceWaypoint, Robot, Site, Waypoint
from robots.models.fleet import ROBOT_CODE
from robots.models.map import UNATTENDED_TO_PICKUP
from robots.names import names_problem
from robots.router import (
    DOCK,
    ELEVATOR,
    STATION,
    MapEdge,
    MapResource,
    MapWaypoint,
    Router,
    SiteMap,
    file_edge_ends,
    site_map_build,
    site_map_from_file,
    straight_line,
)


class SiteFileInvalid(Exception):
    """A site file that cannot be loaded; `problems` names every problem and where it is."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__(f"{len(self.problems)} problem(s) in the site file: {self.problems}")


# --- Reading ----------------------------------------------------------------------------------


# How deep a site file's structure may nest: a real one goes six levels down (floors, a floor,
# its edges, an edge, ...). Deeper is refused before it is built, so a hostile file cannot
# exhaust Python's recursion (a 500) or the validator's time.
MAX_DEPTH = 20
# How many values (mappings, lists and scalars, each alias counted as what it repeats) a file
# may hold: a large hospital's file holds tens of thousands. Aliases (*name) let a few hundred
# bytes stand for millions of values (each level repeating the one before ten times: a
# "billion laughs"), which every later step (the check, the stored draft) would expand.
MAX_VALUES = 200_000


class _UniqueKeyLoader(yaml.SafeLoader):
    """yaml.safe_load, except that a key given twice in one mapping is an error, not a
    silent overwrite (a repeated `code:` would otherwise hide a typo); and that nesting past
    MAX_DEPTH is refused while reading, before Python's recursion runs out."""

    def compose_node(self, parent, index):
        event = self.peek_event()
        self._depth = getattr(self, "_depth", 0) + 1
        try:
            if self._depth > MAX_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {MAX_DEPTH} levels", event.start_mark
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _value in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=deep)
            if not isinstance(key, Hashable):
                continue  # the base class reports unhashable keys
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    "while reading a mapping",
                    node.start_mark,
                    f"duplicate key {key!r}",
                    key_node.start_mark,
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def _json_object(pairs: list[tuple]) -> dict:
    keys = [key for key, _value in pairs]
    repeated = sorted({key for key in keys if keys.count(key) > 1})
    if repeated:
        raise ValueError(f"duplicate key(s) {', '.join(map(repr, repeated))}")
    return dict(pairs)


def _yaml(text: str):
    return yaml.load(text, Loader=_UniqueKeyLoader)  # safe: the loader is a SafeLoader


def _json(text: str):
    return json.loads(text, object_pairs_hook=_json_object)


_PARSERS: dict[str, Callable[[str], object]] = {".yaml": _yaml, ".yml": _yaml, ".json": _json}


def site_file_read(path: str | Path) -> dict:
    """The parsed file; SiteFileInvalid if it is not YAML/JSON holding a mapping.

    OSError (missing, unreadable) propagates unchanged.
    """
    path = Path(path)
    if path.suffix.lower() not in _PARSERS:
        raise SiteFileInvalid([f"{path.name}: expected a .yaml, .yml or .json file"])
    return site_file_parse(path.read_text(encoding="utf-8"), name=path.name)


def site_file_parse(text: str, *, name: str) -> dict:
    """The parsed text of a file called `name` (.json is JSON, anything else YAML, of which
    JSON is a subset); SiteFileInvalid if it is not one or does not hold a mapping."""
    suffix = Path(name).suffix.lower()
    parse = _PARSERS.get(suffix, _yaml)
    kind = suffix[1:] if suffix in _PARSERS else "YAML"
    try:
        data = parse(text)
    except (yaml.YAMLError, ValueError) as exc:
        raise SiteFileInvalid([f"{name}: not valid {kind}: {exc}"]) from None
    except RecursionError:
        raise SiteFileInvalid([f"{name}: nested deeper than {MAX_DEPTH} levels"]) from None
    too_big = _too_big(data)
    if too_big:
        raise SiteFileInvalid([f"{name}: {too_big}"])
    if not isinstance(data, dict):
        raise SiteFileInvalid([f"{name}: the file must hold a mapping (site, floors, ...)"])
    return data


def _too_big(data) -> str | None:
    """Why `data` is too deep or, with its aliases expanded, too large; None if it is not.
    Walked without recursion, and stopped at the first limit passed (an alias may even refer to
    itself)."""
    values, stack = 0, [(data, 1)]
    while stack:
        value, depth = stack.pop()
        values += 1
        if values > MAX_VALUES:
            return f"holds more than {MAX_VALUES} values once its aliases (*name) are expanded"
        if isinstance(value, dict | list):
            if depth > MAX_DEPTH:
                return f"nested deeper than {MAX_DEPTH} levels"
            children = value.values() if isinstance(value, dict) else value
            stack.extend((child, depth + 1) for child in children)
    return None


# --- Validation -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Field:
    type: type | tuple[type, ...]
    required: bool = False
    minimum: float | None = None
    above: float | None = None  # exclusive lower bound
    maximum: float | None = None
    max_length: int | None = None
    pattern: str | None = None
    choices: tuple[str, ...] = ()


NUMBER = (int, float)
CODE_PATTERN = r"\S+"  # codes travel in JSON messages and URLs: no whitespace
TEXT = _Field(str, max_length=200)
POSITIVE = _Field(NUMBER, above=0)


def _code(max_length: int, pattern: str = CODE_PATTERN) -> _Field:
    return _Field(str, required=True, max_length=max_length, pattern=pattern)


SITE_FIELDS = {
    "site": _Field(str, required=True, max_length=64, pattern=r"[-a-zA-Z0-9_]+"),
    "name": TEXT,
    "robot_speed": POSITIVE,
    "heartbeat_interval": POSITIVE,
    "ack_timeout": POSITIVE,
    "offline_timeout": POSITIVE,
    "grant_timeout": POSITIVE,
    "lease_hard_limit": POSITIVE,
    "unload_timeout": POSITIVE,
    "unattended_timeout": POSITIVE,
    "unattended_return": _Field(str, max_length=64, pattern=CODE_PATTERN),
    "stuck_timeout": POSITIVE,
    "battery_threshold": _Field(NUMBER, minimum=0, maximum=1),
    "stat_due_minutes": POSITIVE,
    "urgent_due_minutes": POSITIVE,
    "routine_due_minutes": POSITIVE,
    "stop_dwell_seconds": _Field(NUMBER, minimum=0),
    "battery_per_metre": _Field(NUMBER, minimum=0, maximum=1),
    "battery_per_ride": _Field(NUMBER, minimum=0, maximum=1),
    "battery_reserve": _Field(NUMBER, minimum=0, maximum=1),
    "battery_charged": _Field(NUMBER, minimum=0, maximum=1),
    "floors": _Field(list, required=True),
    "resources": _Field(list),
    "robots": _Field(list),
}
FLOOR_FIELDS = {
    "code": _code(32),
    "level": _Field(int, required=True),
    "name": TEXT,
    "names": _Field(dict),
    "waypoints": _Field(list, required=True),
    "edges": _Field(list),
}
# Metres from a floor's origin a waypoint may lie: wider than any hospital, and small enough
# that the floor's drawing (ui/drawing.py) and travel times stay meaningful; a station typed
# at x = 1e15 would otherwise be accepted and wait for a robot for ever.
COORDINATE_LIMIT = 10_000
COORDINATE = _Field(NUMBER, required=True, minimum=-COORDINATE_LIMIT, maximum=COORDINATE_LIMIT)
WAYPOINT_FIELDS = {
    "code": _code(64),
    "x": COORDINATE,
    "y": COORDINATE,
    "kind": _Field(str, choices=tuple(WaypointKind.values)),
    "name": TEXT,
    "names": _Field(dict),
}
EDGE_FIELDS = {
    "from": _code(64),
    "to": _code(64),
    "length": _Field(NUMBER, minimum=0, maximum=4 * COORDINATE_LIMIT),
    "oneway": _Field(bool),
}
RESOURCE_FIELDS = {
    "code": _code(64),
    "kind": _Field(str, required=True, choices=tuple(ResourceKind.values)),
    "name": TEXT,
    "names": _Field(dict),
    "capacity": _Field(int, minimum=1, maximum=32767),
    "stops": _Field(dict),
    "seconds_per_floor": POSITIVE,
    "overhead_seconds": _Field(NUMBER, minimum=0),
    "waiting": _Field(list),
    "guards": _Field(list),
}
ELEVATOR_ONLY = ("stops", "seconds_per_floor", "overhead_seconds")
PASSAGE_ONLY = ("waiting", "guards")
ROBOT_FIELDS = {
    "code": _code(32, pattern=ROBOT_CODE.regex.pattern.strip("^$")),
    "dock": _code(64),
    "capacity": _Field(int, minimum=1, maximum=32767),
    "name": TEXT,
    "compartments": _Field(list),
    # VDA 5050 vehicles (the vda5050 bridge): protocol vda5050 and both parts of their identity.
    "protocol": _Field(str, choices=tuple(RobotProtocol.values)),
    "manufacturer": _Field(str, max_length=64, pattern=CODE_PATTERN),
    "serial_number": _Field(str, max_length=64, pattern=CODE_PATTERN),
    "vda5050": _Field(dict),
}
# A VDA 5050 vehicle's own needs: the actionParameters of its `pick` and `drop` (for every
# station, and per station code), how often it publishes its state when nothing happens
# (seconds), and the deviations from the standard it needs (VdaQuirk).
VDA5050_FIELDS = {
    "pick": _Field(dict),
    "drop": _Field(dict),
    "stations": _Field(dict),
    "state_interval": _Field(NUMBER, above=0, maximum=3600),
    "lift_wait_alert": _Field(NUMBER, above=0, maximum=3600),
    "quirks": _Field(list),
}
VDA5050_ACTIONS = ("pick", "drop")
# A compartment holds one item; a lockable one opens only for the recipient (secure deliveries).
COMPARTMENT_FIELDS = {
    "code": _code(16),
    "lockable": _Field(bool),
}
MAX_COMPARTMENTS = 32


def site_file_validate(data: dict) -> list[str]:
    """Every problem of a parsed site file, each naming where it is; empty if it is valid."""
    if not isinstance(data, dict):
        return ["the file must hold a mapping (site, floors, ...)"]
    return _Validation(data).run()


_TYPE_NAMES = {
    dict: "a mapping",
    list: "a list",
    str: "a string",
    bool: "a boolean",
    int: "an integer",
    float: "a number",
    type(None): "nothing",
}


def _type_name(value) -> str:
    return _TYPE_NAMES.get(type(value), type(value).__name__)


def _field_problem(spec: _Field, value) -> str | None:
    """Why `value` does not fit `spec`, or None."""
    expected = spec.type if isinstance(spec.type, tuple) else (spec.type,)
    if isinstance(value, bool) and bool not in expected or not isinstance(value, expected):
        wanted = "a number" if expected == NUMBER else _TYPE_NAMES[expected[0]]
        return f"must be {wanted}, not {_type_name(value)} {value!r}"
    if isinstance(value, float) and not math.isfinite(value):
        return f"must be a finite number, not {value!r}"
    return _range_problem(spec, value) or _text_problem(spec, value)


def _range_problem(spec: _Field, value) -> str | None:
    if spec.above is not None and not value > spec.above:
        return f"must be > {spec.above}, not {value!r}"
    if spec.minimum is not None and value < spec.minimum:
        return f"must be >= {spec.minimum}, not {value!r}"
    if spec.maximum is not None and value > spec.maximum:
        return f"must be <= {spec.maximum}, not {value!r}"
    return None


def _text_problem(spec: _Field, value) -> str | None:
    if spec.choices and value not in spec.choices:
        return f"unknown kind {value!r} (expected one of {', '.join(spec.choices)})"
    if spec.max_length is not None and len(value) > spec.max_length:
        return f"is longer than {spec.max_length} characters"
    if spec.pattern is not None and not re.fullmatch(spec.pattern, value):
        return f"{value!r} is not a valid code"
    return None


def _at(path: str, key) -> str:
    return f"{path}.{key}" if path else str(key)


@dataclass
class _Wp:
    """A waypoint as far as it is valid; floor_path tells floors apart even if codes clash."""

    code: str
    kind: str
    floor: str | None
    floor_path: str
    level: int
    x: float | None
    y: float | None
    path: str


class _Validation:
    """One pass over a parsed file, recording every problem and the valid parts seen so far."""

    def __init__(self, data: dict):
        self.data = data
        self.problems: list[str] = []
        self.codes: dict[str, str] = {}  # floor, waypoint and resource codes -> where defined
        self.floors: dict[str, str] = {}  # floor code -> where defined
        self.levels: dict[int, str] = {}
        self.waypoints: dict[str, _Wp] = {}
        self.edges: list[MapEdge] = []
        self.edge_at: dict[tuple[str, str], int] = {}  # each direction travelled -> edge index
        self.edge_paths: list[str] = []
        self.elevators: list[MapResource] = []
        self.waiting: set[str] = set()

    def run(self) -> list[str]:
        site = self._item(self.data, "", SITE_FIELDS) or {}
        floors = site.get("floors", [])
        if "floors" in site and not floors:
            self._problem("floors", "a site needs at least one floor")
        checked = [self._floor(raw, f"floors[{n}]") for n, raw in enumerate(floors)]
        for n, floor in enumerate(checked):
            self._floor_edges(floor, f"floors[{n}]")
        for n, raw in enumerate(site.get("resources", [])):
            self._resource(raw, f"resources[{n}]")
        self._unused_waiting_waypoints()
        self._robots(site.get("robots", []))
        self._unreachable_places()
        self._unattended(site)
        return self.problems

    def _unattended(self, site: dict) -> None:
        """A robot nobody unloads moves on after the unload alert, to a station or back."""
        alert = site.get("unload_timeout", _default(Site, "unload_timeout"))
        moves_on = site.get("unattended_timeout", _default(Site, "unattended_timeout"))
        if (
            isinstance(alert, int | float)
            and isinstance(moves_on, int | float)
            and moves_on <= alert
        ):
            self._problem("unattended_timeout", f"must be longer than unload_timeout ({alert})")
        to = site.get("unattended_return", UNATTENDED_TO_PICKUP)
        if to != UNATTENDED_TO_PICKUP and getattr(self.waypoints.get(to), "kind", "") != STATION:
            self._problem("unattended_return", f"'{UNATTENDED_TO_PICKUP}' or a station's code")

    def _problem(self, where: str, what: str) -> None:
        self.problems.append(f"{where}: {what}" if where else what)

    def _item(self, raw, path: str, fields: dict[str, _Field]) -> dict | None:
        """The keys of `raw` that fit `fields`; reports unknown, missing and ill-typed keys."""
        if not isinstance(raw, dict):
            self._problem(path, f"must be a mapping, not {_type_name(raw)}")
            return None
        for key in raw:
            if key not in fields:
                self._problem(_at(path, key), _unknown_key(key, fields))
        valid = {}
        for key, spec in fields.items():
            if key not in raw:
                if spec.required:
                    self._problem(_at(path, key), "required")
            elif problem := _field_problem(spec, raw[key]) or _names_problem(key, raw[key]):
                self._problem(_at(path, key), problem)
            else:
                valid[key] = raw[key]
        return valid

    def _claim_code(self, code: str | None, path: str) -> bool:
        if code is None:
            return False
        first = self.codes.get(code)
        if first is not None:
            self._problem(f"{path}.code", f"duplicate code '{code}' (also {first})")
            return False
        self.codes[code] = path
        return True

    # Floors and waypoints

    def _floor(self, raw, path: str) -> dict:
        floor = self._item(raw, path, FLOOR_FIELDS)
        if floor is None:
            return {}
        code, level = floor.get("code"), floor.get("level")
        if self._claim_code(code, path):
            self.floors[code] = path
        if level is not None:
            self._claim_level(level, path)
        if "waypoints" in floor and not floor["waypoints"]:
            self._problem(f"{path}.waypoints", "a floor needs at least one waypoint")
        for n, wp in enumerate(floor.get("waypoints", [])):
            self._waypoint(wp, f"{path}.waypoints[{n}]", floor, path)
        return floor

    def _claim_level(self, level: int, path: str) -> None:
        first = self.levels.setdefault(level, path)
        if first != path:
            self._problem(f"{path}.level", f"duplicate level {level} (also {first})")

    def _waypoint(self, raw, path: str, floor: dict, floor_path: str) -> None:
        wp = self._item(raw, path, WAYPOINT_FIELDS)
        if wp is None or not self._claim_code(wp.get("code"), path):
            return
        self.waypoints[wp["code"]] = _Wp(
            code=wp["code"],
            kind=wp.get("kind", WaypointKind.PLAIN),
            floor=floor.get("code"),
            floor_path=floor_path,
            level=floor.get("level", 0),
            x=wp.get("x"),
            y=wp.get("y"),
            path=path,
        )

    # Edges

    def _floor_edges(self, floor: dict, floor_path: str) -> None:
        for n, raw in enumerate(floor.get("edges", [])):
            self._edge(raw, f"{floor_path}.edges[{n}]", floor, floor_path)

    def _edge(self, raw, path: str, floor: dict, floor_path: str) -> None:
        ends = self._edge_ends(raw, path)
        if ends is None:
            return
        source, target, length, oneway = ends
        known = [self._edge_end(code, path, floor, floor_path) for code in (source, target)]
        if not all(known):  # both ends checked, so both get reported
            return
        if source == target:
            self._problem(path, f"an edge from '{source}' to itself")
            return
        directions = [(source, target)] if oneway else [(source, target), (target, source)]
        clash = next((self.edge_at[d] for d in directions if d in self.edge_at), None)
        if clash is not None:
            also = self.edge_paths[clash]
            self._problem(path, f"duplicate edge '{source}' - '{target}' (also {also})")
            return
        if length is None:
            length = self._straight_line(source, target)
        for direction in directions:
            self.edge_at[direction] = len(self.edges)
        self.edges.append(MapEdge(source, target, float(length), oneway, None))
        self.edge_paths.append(path)

    def _edge_ends(self, raw, path: str) -> tuple | None:
        if isinstance(raw, list):
            if _is_pair(raw):
                return file_edge_ends(raw)
            self._problem(path, "an edge is [A, B] or {from, to, length, oneway}")
            return None
        edge = self._item(raw, path, EDGE_FIELDS)
        if edge is None or "from" not in edge or "to" not in edge:
            return None
        return file_edge_ends(edge)

    def _edge_end(self, code: str, path: str, floor: dict, floor_path: str) -> bool:
        wp = self.waypoints.get(code)
        if wp is None:
            self._problem(path, f"unknown waypoint '{code}'")
            return False
        if wp.floor_path != floor_path:
            self._problem(
                path,
                f"waypoint '{code}' is on floor '{wp.floor}', not '{floor.get('code')}'; "
                "floors connect only through elevators",
            )
            return False
        return True

    def _straight_line(self, source: str, target: str) -> float:
        a, b = self.waypoints[source], self.waypoints[target]
        if None in (a.x, a.y, b.x, b.y):
            return 0.0  # a position is already reported; any length serves the checks left
        return straight_line(_map_waypoint(a), _map_waypoint(b))

    # Resources

    def _resource(self, raw, path: str) -> None:
        resource = self._item(raw, path, RESOURCE_FIELDS)
        if resource is None:
            return
        self._claim_code(resource.get("code"), path)
        kind = resource.get("kind")
        if kind == ELEVATOR:
            self._elevator(resource, raw, path)
        elif kind is not None:
            self._passage(resource, raw, path)

    def _kind_keys(self, raw: dict, path: str, *, required: tuple, foreign: tuple) -> None:
        kind = raw["kind"]
        for key in required:
            if key not in raw:
                self._problem(_at(path, key), f"required for {_a(kind)}")
        for key in foreign:
            if key in raw:
                self._problem(_at(path, key), f"{_a(kind)} has no '{key}'")

    def _elevator(self, resource: dict, raw: dict, path: str) -> None:
        self._kind_keys(raw, path, required=ELEVATOR_ONLY, foreign=PASSAGE_ONLY)
        stops = resource.get("stops", {})
        if "stops" in resource and len(stops) < 2:
            self._problem(f"{path}.stops", "an elevator needs at least 2 stops")
        valid = [wp for floor, wp in stops.items() if self._stop_valid(floor, wp, f"{path}.stops")]
        self.waiting.update(valid)
        self.elevators.append(
            MapResource(
                id=0,
                code=resource.get("code", path),
                name="",
                kind=ELEVATOR,
                capacity=1,
                seconds_per_floor=resource.get("seconds_per_floor", 0.0),
                overhead_seconds=resource.get("overhead_seconds", 0.0),
                waypoints=tuple(valid),
            )
        )

    def _stop_valid(self, floor_code, wp_code, path: str) -> bool:
        floor_path = self.floors.get(floor_code) if isinstance(floor_code, str) else None
        if floor_path is None:
            self._problem(path, f"floor '{floor_code}' does not exist")
            return False
        wp = self.waypoints.get(wp_code) if isinstance(wp_code, str) else None
        if wp is None:
            self._problem(path, f"unknown waypoint '{wp_code}' (stop on floor '{floor_code}')")
            return False
        if wp.floor_path != floor_path:
            self._problem(
                path, f"waypoint '{wp_code}' is on floor '{wp.floor}', not '{floor_code}'"
            )
            return False
        return True

    def _passage(self, resource: dict, raw: dict, path: str) -> None:
        """A door or corridor: waiting waypoints, and the edges it guards."""
        self._kind_keys(raw, path, required=PASSAGE_ONLY, foreign=ELEVATOR_ONLY)
        kind, code = raw["kind"], resource.get("code")
        if "waiting" in resource and not resource["waiting"]:
            self._problem(f"{path}.waiting", f"a {kind} needs at least one waiting waypoint")
        for n, wp in enumerate(resource.get("waiting", [])):
            if not isinstance(wp, str) or wp not in self.waypoints:
                self._problem(f"{path}.waiting[{n}]", f"unknown waypoint '{wp}'")
            else:
                self.waiting.add(wp)
        if "guards" in resource and not resource["guards"]:
            self._problem(f"{path}.guards", f"a {kind} needs at least one guarded edge")
        for n, pair in enumerate(resource.get("guards", [])):
            self._guard(pair, code, f"{path}.guards[{n}]")

    def _guard(self, pair, resource_code: str | None, path: str) -> None:
        if not _is_pair(pair):
            self._problem(path, "a guard is a pair of waypoint codes [A, B]")
            return
        index = self.edge_at.get(tuple(pair))
        if index is None:
            self._problem(path, f"'{pair[0]}' - '{pair[1]}' is not an edge of the file")
            return
        edge = self.edges[index]
        if edge.guarded_by is not None:
            self._problem(
                path, f"'{pair[0]}' - '{pair[1]}' is already guarded by '{edge.guarded_by}'"
            )
            return
        self.edges[index] = MapEdge(
            edge.source, edge.target, edge.length, edge.oneway, resource_code or path
        )

    def _unused_waiting_waypoints(self) -> None:
        for wp in self.waypoints.values():
            if wp.kind == WaypointKind.RESOURCE_WAIT and wp.code not in self.waiting:
                self._problem(
                    wp.path,
                    f"'{wp.code}' is of kind resource_wait but no resource waits there "
                    "(list it in a resource's stops or waiting, or make it plain)",
                )
            if wp.kind == WaypointKind.REFUGE and wp.code in self.waiting:
                self._problem(
                    wp.path,
                    f"'{wp.code}' is a refuge point but a resource waits there: a refuge "
                    "must be off the lobbies, doorways and corridors robots pass through",
                )

    # Robots

    def _robots(self, robots: list) -> None:
        seen: dict[str, str] = {}
        seen_identities: dict[tuple, str] = {}
        for n, raw in enumerate(robots):
            path = f"robots[{n}]"
            robot = self._item(raw, path, ROBOT_FIELDS)
            if robot is None:
                continue
            code = robot.get("code")
            if code is not None and seen.setdefault(code, path) != path:
                self._problem(f"{path}.code", f"duplicate robot code '{code}' (also {seen[code]})")
            if "dock" in robot:
                self._dock(robot["dock"], f"{path}.dock")
            if "compartments" in robot:
                self._compartments(robot, path)
            self._vda5050_identity(robot, path, seen_identities)
            if "vda5050" in robot:
                self._vda5050_options(robot, f"{path}.vda5050")

    def _vda5050_identity(self, robot: dict, path: str, seen: dict) -> None:
        """A VDA 5050 vehicle names its manufacturer and serial number (its MQTT topics do);
        a heartbeat robot names neither."""
        vda = robot.get("protocol") == RobotProtocol.VDA5050
        for name in ("manufacturer", "serial_number"):
            if vda and not robot.get(name):
                self._problem(f"{path}.{name}", "required for a vda5050 robot")
            if not vda and name in robot:
                self._problem(f"{path}.{name}", "only for a robot of protocol vda5050")
        identity = (robot.get("manufacturer"), robot.get("serial_number"))
        if vda and all(identity) and seen.setdefault(identity, path) != path:
            self._problem(f"{path}.serial_number", f"duplicate vehicle {identity[0]}/{identity[1]}")

    def _vda5050_options(self, robot: dict, path: str) -> None:
        if robot.get("protocol") != RobotProtocol.VDA5050:
            self._problem(path, "only for a robot of protocol vda5050")
            return
        options = self._item(robot["vda5050"], path, VDA5050_FIELDS) or {}
        for kind in VDA5050_ACTIONS:
            if kind in options:
                self._action_parameters(options[kind], f"{path}.{kind}")
        for code, actions in options.get("stations", {}).items():
            where = f"{path}.stations.{code}"
            if getattr(self.waypoints.get(code), "kind", "") != STATION:
                self._problem(where, f"'{code}' is not a station's code")
            station = self._item(actions, where, {kind: _Field(dict) for kind in VDA5050_ACTIONS})
            for kind, parameters in (station or {}).items():
                self._action_parameters(parameters, f"{where}.{kind}")
        for n, quirk in enumerate(options.get("quirks", [])):
            if quirk not in VdaQuirk.values:
                self._problem(f"{path}.quirks[{n}]", f"one of {', '.join(VdaQuirk.values)}")

    def _action_parameters(self, parameters: dict, path: str) -> None:
        """actionParameters as key: value, each value a string, a number or a boolean."""
        for key, value in parameters.items():
            if not isinstance(value, str | int | float | bool) or len(str(value)) > 200:
                self._problem(_at(path, key), "must be a string, a number or a boolean")

    def _compartments(self, robot: dict, path: str) -> None:
        """Each compartment holds one item, so they set the robot's capacity."""
        compartments = robot["compartments"]
        if not 1 <= len(compartments) <= MAX_COMPARTMENTS:
            self._problem(f"{path}.compartments", f"list 1 to {MAX_COMPARTMENTS} compartments")
        seen: set[str] = set()
        for n, raw in enumerate(compartments):
            compartment = self._item(raw, f"{path}.compartments[{n}]", COMPARTMENT_FIELDS)
            code = (compartment or {}).get("code")
            if code is not None and code in seen:
                self._problem(f"{path}.compartments[{n}].code", f"duplicate compartment '{code}'")
            seen.add(code)
        if "capacity" in robot and robot["capacity"] != len(compartments):
            self._problem(
                f"{path}.capacity",
                f"{robot['capacity']} differs from its {len(compartments)} compartments "
                "(one item each): leave capacity out",
            )

    def _dock(self, code: str, path: str) -> None:
        wp = self.waypoints.get(code)
        if wp is None:
            self._problem(path, f"unknown waypoint '{code}'")
        elif wp.kind != WaypointKind.DOCK:
            self._problem(path, f"'{code}' is a {wp.kind} waypoint, not a dock")

    # Reachability

    def _unreachable_places(self) -> None:
        """Every station and dock must be reachable from every other (floors joined by the
        elevators' stops); whatever is cut off from the biggest mutually reachable group is
        reported against one member of that group."""
        router = Router(self._site_map())
        places = router.site_map.codes_of_kind(STATION, DOCK)
        reach = {code: router.travel_times_from(code) for code in places}
        groups = {a: {b for b in places if b in reach[a] and a in reach[b]} for a in places}
        hub = max(places, key=lambda code: len(groups[code]), default=None)
        for code in places:
            if code not in groups[hub]:
                self._report_cut_off(code, hub, there=code in reach[hub], back=hub in reach[code])

    def _report_cut_off(self, code: str, hub: str, *, there: bool, back: bool) -> None:
        if there:
            how = f"no route from it back to '{hub}'"
        elif back:
            how = f"no route to it from '{hub}'"
        else:
            how = f"no route to or from '{hub}'"
        wp = self.waypoints[code]
        self._problem(wp.path, f"{wp.kind} '{code}' is unreachable: {how}")

    def _site_map(self) -> SiteMap:
        """The valid parts seen, as a map to search (ids and speed do not matter here)."""
        return site_map_build(
            site_id=0,
            map_version=0,
            robot_speed=1.0,
            floors=[],
            waypoints=[_map_waypoint(wp) for wp in self.waypoints.values()],
            edges=self.edges,
            resources=self.elevators,
        )


def _a(noun: str) -> str:
    return f"an {noun}" if noun[:1] in "aeiou" else f"a {noun}"


def _is_pair(value) -> bool:
    return isinstance(value, list) and len(value) == 2 and all(isinstance(c, str) for c in value)


def _map_waypoint(wp: _Wp) -> MapWaypoint:
    return MapWaypoint(
        id=0,
        code=wp.code,
        name="",
        kind=wp.kind,
        floor=wp.floor or "",
        level=wp.level,
        x=float(wp.x or 0.0),
        y=float(wp.y or 0.0),
    )


def _names_problem(key: str, value) -> str | None:
    return names_problem(value) if key == "names" else None


def _unknown_key(key, fields: dict) -> str:
    close = difflib.get_close_matches(str(key), list(fields), n=1)
    hint = f"did you mean '{close[0]}'?" if close else f"expected one of {', '.join(fields)}"
    return f"unknown key ({hint})"


# --- Loading ----------------------------------------------------------------------------------

SITE_SETTINGS = [
    "name",
    "robot_speed",
    "heartbeat_interval",
    "ack_timeout",
    "offline_timeout",
    "grant_timeout",
    "lease_hard_limit",
    "unload_timeout",
    "unattended_timeout",
    "unattended_return",
    "stuck_timeout",
    "battery_threshold",
    "stat_due_minutes",
    "urgent_due_minutes",
    "routine_due_minutes",
    "stop_dwell_seconds",
    "battery_per_metre",
    "battery_per_ride",
    "battery_reserve",
    "battery_charged",
]


def site_load(*, data: dict) -> Site:
    """Create or update the site a valid file describes, all in one transaction.

    Rows are matched by code (edges by their ends) so unchanged things keep their primary
    keys; what the file no longer has is deleted; robots in the file are created or updated
    (never their token or reported state). Bumps map_version so routing caches refresh.
    Raises SiteFileInvalid, having written nothing, if the file or the database forbids it.
    """
    problems = site_file_validate(data)
    if problems:
        raise SiteFileInvalid(problems)
    plan = site_map_from_file(data)
    robots = data.get("robots", [])
    with transaction.atomic():
        site = Site.objects.select_for_update().filter(code=data["site"]).first()
        problems = _robots_elsewhere(site, robots) + _docks_dropped(site, robots, plan)
        if problems:
            raise SiteFileInvalid(problems)
        site = _site_save(site, data)
        stale = _map_write(site, plan)
        _robots_write(site, robots, plan)
        for model, pks in stale:
            _rows_delete(model, pks)
    return site


def _robots_elsewhere(site: Site | None, robots: list[dict]) -> list[str]:
    """Robot codes are unique across sites; a file may not take over another site's robot."""
    index = {robot["code"]: n for n, robot in enumerate(robots)}
    others = Robot.objects.filter(code__in=index).select_related("site")
    if site is not None:
        others = others.exclude(site=site)
    return [
        f"robots[{index[robot.code]}].code: robot '{robot.code}' belongs to site "
        f"'{robot.site.code}'"
        for robot in others
    ]


def _docks_dropped(site: Site | None, robots: list[dict], plan: SiteMap) -> list[str]:
    """Robots of the site that the file does not list keep their dock, so it must stay."""
    if site is None:
        return []
    kept = Robot.objects.filter(site=site).exclude(code__in=[r["code"] for r in robots])
    problems = []
    for robot in kept.select_related("dock").order_by("code"):
        dock = plan.waypoints.get(robot.dock.code)
        if dock is None or dock.kind != DOCK:
            problems.append(
                f"robots: robot '{robot.code}' (not in the file) docks at '{robot.dock.code}', "
                "which the file no longer has as a dock; list the robot with a new dock"
            )
    return problems


def _site_save(site: Site | None, data: dict) -> Site:
    values = {name: data.get(name, _default(Site, name)) for name in SITE_SETTINGS}
    now = timezone.now()
    if site is None:
        return Site.objects.create(code=data["site"], loaded_at=now, **values)
    for name, value in values.items():
        setattr(site, name, value)
    site.map_version += 1
    site.loaded_at = now
    site.save(update_fields=[*values, "map_version", "loaded_at"])
    return site


def _default(model: type[models.Model], field: str):
    return model._meta.get_field(field).get_default()


def _map_write(site: Site, plan: SiteMap) -> list[tuple[type[models.Model], list[int]]]:
    """Upsert floors, waypoints, resources, their waiting waypoints and edges; returns the rows
    the file no longer has, to delete once robots have moved off them (in this order)."""
    floor_ids, stale_floors = _rows_sync(
        site.floors.all(), _floor_rows(site, plan), key=lambda row: row.code
    )
    waypoint_ids, stale_waypoints = _rows_sync(
        site.waypoints.all(), _waypoint_rows(site, plan, floor_ids), key=lambda row: row.code
    )
    resource_ids, stale_resources = _rows_sync(
        site.resources.all(), _resource_rows(site, plan), key=lambda row: row.code
    )
    _ids, stale_stops = _rows_sync(
        ResourceWaypoint.objects.filter(resource__site=site),
        _stop_rows(plan, resource_ids, waypoint_ids),
        key=lambda row: (row.resource_id, row.waypoint_id),
    )
    _ids, stale_edges = _rows_sync(
        site.edges.all(),
        _edge_rows(site, plan, waypoint_ids, resource_ids),
        key=lambda row: (row.source_id, row.target_id),
    )
    return [
        (Edge, stale_edges),
        (ResourceWaypoint, stale_stops),
        (Resource, stale_resources),
        (Waypoint, stale_waypoints),
        (Floor, stale_floors),
    ]


def _floor_rows(site: Site, plan: SiteMap) -> dict[str, dict]:
    return {
        code: {
            "site_id": site.pk,
            "code": code,
            "level": level,
            "name": plan.floor_names[code],
            "names": dict(plan.floor_names_by_language.get(code, ())),
        }
        for code, level in plan.floors.items()
    }


def _waypoint_rows(site: Site, plan: SiteMap, floor_ids: dict[str, int]) -> dict[str, dict]:
    return {
        wp.code: {
            "site_id": site.pk,
            "floor_id": floor_ids[wp.floor],
            "code": wp.code,
            "name": wp.name,
            "names": dict(wp.names),
            "kind": wp.kind,
            "x": wp.x,
            "y": wp.y,
        }
        for wp in plan.waypoints.values()
    }


def _resource_rows(site: Site, plan: SiteMap) -> dict[str, dict]:
    return {
        r.code: {
            "site_id": site.pk,
            "code": r.code,
            "name": r.name,
            "names": dict(r.names),
            "kind": r.kind,
            "capacity": r.capacity,
            "seconds_per_floor": r.seconds_per_floor,
            "overhead_seconds": r.overhead_seconds,
        }
        for r in plan.resources.values()
    }


def _stop_rows(plan: SiteMap, resource_ids: dict, waypoint_ids: dict) -> dict[tuple, dict]:
    rows = {}
    for r in plan.resources.values():
        for wp in r.waypoints:
            key = (resource_ids[r.code], waypoint_ids[wp])
            rows[key] = {"resource_id": key[0], "waypoint_id": key[1]}
    return rows


def _edge_rows(site: Site, plan: SiteMap, waypoint_ids: dict, resource_ids: dict) -> dict:
    rows = {}
    for edge in plan.edges:
        key = (waypoint_ids[edge.source], waypoint_ids[edge.target])
        rows[key] = {
            "site_id": site.pk,
            "source_id": key[0],
            "target_id": key[1],
            "length": edge.length,
            "oneway": edge.oneway,
            "guarded_by_id": resource_ids.get(edge.guarded_by),
        }
    return rows


def _robots_write(site: Site, robots: list[dict], plan: SiteMap) -> None:
    docks = dict(site.waypoints.filter(kind=WaypointKind.DOCK).values_list("code", "id"))
    wanted = {}
    for robot in robots:
        wanted[robot["code"]] = {
            "site_id": site.pk,
            "code": robot["code"],
            "dock_id": docks[robot["dock"]],
            "capacity": robot.get("capacity", _default(Robot, "capacity")),
            "compartments": _compartments(robot),
            "protocol": robot.get("protocol", RobotProtocol.HEARTBEAT),
            "manufacturer": robot.get("manufacturer", ""),
            "serial_number": robot.get("serial_number", ""),
            "vda5050": robot.get("vda5050", {}),
        }
        if robot.get("compartments"):
            wanted[robot["code"]]["capacity"] = len(robot["compartments"])
        if "name" in robot:  # a name set by an operator stays unless the file gives one
            wanted[robot["code"]]["name"] = robot["name"]
    _rows_sync(Robot.objects.filter(code__in=wanted), wanted, key=lambda row: row.code)


def _compartments(robot: dict) -> list[dict]:
    return [
        {"code": c["code"], "lockable": bool(c.get("lockable", False))}
        for c in robot.get("compartments", [])
    ]


def _rows_sync(
    queryset: models.QuerySet, wanted: dict[Hashable, dict], *, key: Callable
) -> tuple[dict[Hashable, int], list[int]]:
    """Make the rows of `queryset` hold `wanted` (key -> field values): update rows whose
    values differ, create missing ones. Returns key -> pk, and the pks of rows not wanted."""
    model = queryset.model
    existing = {key(row): row for row in queryset}
    changed, fields = [], set()
    for row_key, values in wanted.items():
        row = existing.get(row_key)
        if row is None:
            continue
        differing = [name for name, value in values.items() if getattr(row, name) != value]
        for name in differing:
            setattr(row, name, values[name])
        if differing:
            changed.append(row)
            fields.update(differing)
    if changed:
        model.objects.bulk_update(changed, sorted(fields))
    created = model.objects.bulk_create(
        [model(**values) for row_key, values in wanted.items() if row_key not in existing]
    )
    ids = {key(row): row.pk for row in [*existing.values(), *created]}
    return ids, [row.pk for row_key, row in existing.items() if row_key not in wanted]


def _rows_delete(model: type[models.Model], pks: list[int]) -> None:
    if not pks:
        return
    try:
        model.objects.filter(pk__in=pks).delete()
    except (ProtectedError, RestrictedError) as exc:
        blockers = getattr(exc, "protected_objects", None) or exc.restricted_objects
        used_by = ", ".join(sorted({f"{type(obj).__name__} {obj}" for obj in blockers})[:10])
        raise SiteFileInvalid(
            [
                f"{model._meta.verbose_name_plural}: the file drops some that are still "
                f"in use ({used_by})"
            ]
        ) from None
