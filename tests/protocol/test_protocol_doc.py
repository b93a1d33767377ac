"""docs/robot-protocol.md against the server: every JSON example in the robot integrators'
guide goes through the server's own validation, so the guide cannot drift from the code.

Every fenced JSON block of the document carries one of these tags in its info string
(```json <tag>); an untagged or unparseable JSON block fails the first test below.

    heartbeat-request       a body the heartbeat endpoint accepts: valid for HeartbeatSerializer
                            with the Eulji map, and answered 200 when POSTed (all of them in the
                            document's order, as R3)
    bad-heartbeat-request   a body it refuses; the next JSON block is its error-400, whose status,
                            error code and field paths POSTing it reproduces
    heartbeat-response      a whole 200 answer: its fields by HeartbeatResponseSerializer, its
                            messages as message-* below
    message-plan, message-resource_grant, message-resource_queued, message-action
                            one board message: the documentation serializer of its type (dock
                            stops, which PlanStopSerializer does not describe, by their own rule),
                            every code in the Eulji map and every `via` as its router finds it;
                            together, exactly the fields of the messages the server really posts
                            in a scripted delivery, elevator ride and operator pause
    error-400               {"error": "invalid" | "invalid_json", "detail": {path: [reason, ...]}},
                            every path a field of the heartbeat
    error-401, error-403, error-413
                            the error code the server answers in that case, reproduced
    push-wake               exactly {"type": "wake", "message": "m-<digits>"}

The document must also mention every event, message and request type, status, presence and
action, and its table of request fields must give each field's JSON type, whether it is
required or nullable, and the serializer's limits.
"""

import json
import math
import re
from dataclasses import dataclass
from datetime import timedelta
from functools import cache
from pathlib import Path

import pytest
from django.conf import settings
from django.utils import timezone
from django.utils.dateparse import parse_datetime
from rest_framework import serializers

# --- Server imports: all here, so that a moved module is one line to update ----------------------
from boards.choices import EventType, MessageType, RequestType
from boards.models import BoardMessage
from boards.serializers import (
    BoardMessageSerializer,
    HeartbeatResponseSerializer,
    HeartbeatSerializer,
    PlanStopSerializer,
)
from building.models import Device
from building.services import sim_step
from core.errors import flatten_errors
from core.overload import heartbeat_interval_spread
from resources.availability import resource_return_to_service, resource_take_out_of_service
from robots.badges import BadgeHash, badge_matches
from robots.choices import REPORTABLE_STATUSES, Presence
from robots.mapcache import router_for, site_map
from robots.models import Resource, Robot, Waypoint
from robots.services import robot_token_issue
from robots.sitefile import site_file_read, site_load
from robotsim.client import badge_check, pin_check
from scheduling.models import Task, TaskStop
from scheduling.pins import ALGORITHM, ITERATIONS, PinHash, pin_matches
from scheduling.services import emergency_start, robot_action

# -------------------------------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "robot-protocol.md"
SITE_FILE = ROOT / "sites" / "eulji.yaml"

MESSAGE_TAGS = {f"message-{message_type}": message_type for message_type in MessageType.values}
TAGS = {
    "heartbeat-request",
    "bad-heartbeat-request",
    "heartbeat-response",
    *MESSAGE_TAGS,
    "error-400",
    "error-401",
    "error-403",
    "error-413",
    "push-wake",
}
HEARTBEAT_TAGS = {"heartbeat-request", "bad-heartbeat-request"}
REPLAYED_ROBOT = "R3"
DOCK = "dock"
REFUGE = "refuge"


# --- Reading the document -----------------------------------------------------------------------


@dataclass(frozen=True)
class Block:
    line: int
    language: str
    tag: str
    text: str

    def __str__(self):
        return f"{DOC.name}:{self.line} ({' '.join(filter(None, [self.language, self.tag]))})"

    @property
    def data(self):
        try:
            return json.loads(self.text)
        except ValueError as exc:
            raise AssertionError(f"{self}: not JSON: {exc}") from None


@cache
def doc_text() -> str:
    return DOC.read_text(encoding="utf-8")


@cache
def blocks() -> tuple[Block, ...]:
    """Every fenced block of the document, in order."""
    found, lines, index = [], doc_text().splitlines(), 0
    while index < len(lines):
        opening = re.match(r"^```(\S*)[ \t]*(.*?)\s*$", lines[index])
        if opening:
            start, body = index, []
            index += 1
            while index < len(lines) and lines[index].strip() != "```":
                body.append(lines[index])
                index += 1
            assert index < len(lines), f"{DOC.name}:{start + 1}: code block never closed"
            found.append(Block(start + 1, opening[1], opening[2], "\n".join(body)))
        index += 1
    return tuple(found)


def tagged(*tags: str) -> list[Block]:
    return [block for block in blocks() if block.language == "json" and block.tag in tags]


def examples(*tags: str) -> list[tuple[Block, dict]]:
    return [(block, block.data) for block in tagged(*tags)]


def backticked() -> set[str]:
    return set(re.findall(r"`([^`\n]+)`", doc_text()))


def tables() -> list[list[dict[str, str]]]:
    """The document's tables, each a list of rows {header: cell}."""
    found, rows, header = [], [], None
    for line in [*doc_text().splitlines(), ""]:
        if not line.startswith("|"):
            if header is not None:
                found.append(rows)
            rows, header = [], None
            continue
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if header is None:
            header = cells
        elif not all(re.fullmatch(r":?-+:?", cell) for cell in cells):
            rows.append(dict(zip(header, cells, strict=False)))
    return found


def table_with(*headers: str) -> dict[str, dict[str, str]]:
    """The table with these headers, by its first column without backticks."""
    for rows in tables():
        if rows and all(name in rows[0] for name in headers):
            first = next(iter(rows[0]))
            return {row[first].strip("`"): row for row in rows}
    raise AssertionError(f"{DOC.name} has no table with columns {headers}")


def messages_of(block: Block, data: dict) -> list[tuple[str, dict]]:
    """(where, message) of a message-* block or of each message of a heartbeat-response."""
    if block.tag == "heartbeat-response":
        return [(f"{block} messages[{n}]", message) for n, message in enumerate(data["messages"])]
    return [(str(block), data)]


def all_messages() -> list[tuple[str, dict]]:
    return [
        found
        for block, data in examples("heartbeat-response", *MESSAGE_TAGS)
        for found in messages_of(block, data)
    ]


# --- The server side ------------------------------------------------------------------------------


@pytest.fixture
def eulji(db):
    return site_load(data=site_file_read(SITE_FILE))


@pytest.fixture
def eulji_map(eulji):
    return site_map(eulji)


@pytest.fixture
def tokens(eulji) -> dict[str, str]:
    robots = Robot.objects.filter(site=eulji)
    return {robot.code: robot_token_issue(robot=robot) for robot in robots}


def post(client, robot: str, token: str, body) -> tuple[int, object]:
    raw = body if isinstance(body, str | bytes) else json.dumps(body)
    response = client.post(
        f"/api/v1/robots/{robot}/heartbeat",
        data=raw,
        content_type="application/json",
        headers={"Authorization": f"Bearer {token}"},
    )
    return response.status_code, response.json()


def message_serializer(message_type: str):
    """The documentation serializer the OpenAPI schema gives messages of this type."""
    proxy = getattr(BoardMessageSerializer, "child", BoardMessageSerializer)  # many=True
    return proxy.serializers[message_type]


def heartbeat_fields(serializer=None, prefix=""):
    """(path, field) of every field of a heartbeat, as the document's table names them."""
    serializer = serializer or HeartbeatSerializer()
    for name, field in serializer.fields.items():
        path = f"{prefix}{name}"
        yield path, field
        if isinstance(field, serializers.ListSerializer):
            yield from heartbeat_fields(field.child, f"{path}[].")
        elif isinstance(field, serializers.Serializer):
            yield from heartbeat_fields(field, f"{path}.")


def json_type(field) -> str:
    if isinstance(field, serializers.ListSerializer):
        return "list of objects"
    if isinstance(field, serializers.ListField):
        return f"list of {json_type(field.child)}s"
    if isinstance(field, serializers.Serializer):
        return "object"
    if isinstance(field, serializers.DateTimeField):
        return "string (date-time)"
    if isinstance(field, serializers.IntegerField):
        return "integer"
    if isinstance(field, serializers.FloatField):
        return "number"
    if isinstance(field, serializers.CharField | serializers.ChoiceField):
        return "string"
    if isinstance(field, serializers.BooleanField):
        return "boolean"
    raise AssertionError(f"no JSON type known for {field!r}")


WRONG_TYPES = {
    "integer": ["12", True, 12.0, None],
    "number": ["0.5", True, math.nan, None],
    "string": [3, True, ["x"], None],
    "string (date-time)": [3, True, None],
    "object": ["x", [1], None],
    "list of objects": [{"id": "x"}, "x", None],
    "list of strings": ["x", {"x": 1}, None],
    "boolean": ["true", 1, 0, None],
}


def limits(field) -> list[float]:
    names = ["min_length", "max_length", "min_value", "max_value"]
    found = [getattr(field, name, None) for name in names]
    if isinstance(field, serializers.ListField):
        found += limits(field.child)
    return [value for value in found if value is not None]


def heartbeat_path_pattern() -> re.Pattern:
    """Field paths a 400 about a heartbeat may name: "state.battery", "events[3].task",
    "acks[2]", "events", "body"."""
    alternatives = ["body"]
    for path, field in heartbeat_fields():
        regex = re.escape(path).replace(r"\[\]", r"\[\d+\]")
        alternatives.append(regex)
        if isinstance(field, serializers.ListSerializer | serializers.ListField):
            alternatives.append(regex + r"\[\d+\]")
    return re.compile("|".join(f"(?:{alternative})" for alternative in alternatives))


def task_stops_documented() -> dict[str, dict]:
    """Each task code in the documented plans: its details and its stops {index: stop}."""
    tasks: dict[str, dict] = {}
    for where, message in all_messages():
        if message["type"] != MessageType.PLAN:
            continue
        for code, details in message["tasks"].items():
            task = tasks.setdefault(code, {"details": details, "stops": {}})
            assert task["details"] == details, f"{where}: {code} is described differently"
        for stop in message["stops"]:
            if stop["action"] == DOCK:
                continue
            known = tasks[stop["task"]]["stops"].setdefault(stop["stop"], stop)
            same = (known["action"], known["waypoint"]) == (stop["action"], stop["waypoint"])
            assert same, f"{where}: {stop['task']} stop {stop['stop']} changes meaning"
    return tasks


def documented_tasks_create(site) -> None:
    """The documented tasks, with their codes and stops, for events to name. Finished and with
    no robot: the heartbeat checks the codes and stops, and changes nothing about them."""
    now = timezone.now()
    waypoints = {waypoint.code: waypoint for waypoint in Waypoint.objects.filter(site=site)}
    for code, task in task_stops_documented().items():
        unknown = [stop["waypoint"] for stop in task["stops"].values()]
        unknown = [waypoint for waypoint in unknown if waypoint not in waypoints]
        assert not unknown, f"{code} stops at {unknown}, not on the Eulji map"
        details = dict(task["details"])
        secure = details.pop("secure", None)
        created = Task.objects.create(
            pk=int(code.removeprefix("T-")),
            site=site,
            status="completed",
            requested_time=now - timedelta(hours=1),
            **details,
            **(secure_fields(secure) if secure else {}),
        )
        assert created.code == code, f"task code {code} is not what the server would call it"
        TaskStop.objects.bulk_create(
            TaskStop(
                task=created,
                index=index,
                action=stop["action"],
                waypoint=waypoints[stop["waypoint"]],
                load_change=1 if stop["action"] == "pickup" else -1,
            )
            for index, stop in task["stops"].items()
        )


def secure_fields(secure: dict) -> dict:
    pin = secure["pin"]
    return {
        "secure": True,
        "pin_salt": pin["salt"],
        "pin_iterations": pin["iterations"],
        "pin_hash": pin["hash"],
    }


# --- The document as a whole ----------------------------------------------------------------------


def test_it_tags_every_json_block_and_each_parses():
    for block in blocks():
        if block.language == "json":
            assert block.tag in TAGS, f"{block}: JSON block without a known tag {sorted(TAGS)}"
            assert isinstance(block.data, dict), f"{block}: not a JSON object"
        else:
            try:
                json.loads(block.text)
            except ValueError:
                continue
            raise AssertionError(f"{block}: JSON not marked as ```json <tag>")
    used = {block.tag for block in blocks() if block.language == "json"}
    assert used == TAGS, f"tags without an example: {sorted(TAGS - used)}"


def test_it_mentions_every_value_robots_send_or_receive():
    stop_actions = PlanStopSerializer().fields["action"].choices
    commands = message_serializer(MessageType.ACTION)().fields["action"].choices
    values = {
        "event type": EventType.values,
        "message type": MessageType.values,
        "request type": RequestType.values,
        "status": REPORTABLE_STATUSES,
        "presence": Presence.values,
        "plan stop action": list(stop_actions),
        "operator action": list(commands),
    }
    mentioned = backticked()
    for kind, wanted in values.items():
        missing = [value for value in wanted if value not in mentioned]
        assert not missing, f"{DOC.name} never mentions the {kind}(s) {missing}"


def test_it_documents_every_request_field_with_its_type_requirement_and_limits():
    rows = table_with("field", "type", "required", "limits", "meaning")
    for path, field in heartbeat_fields():
        assert path in rows, f"{DOC.name}: no row for request field `{path}`"
        row = rows[path]
        assert row["type"] == json_type(field), f"`{path}` is a {json_type(field)}: {row}"
        assert (row["required"] == "yes") == field.required, f"`{path}` required? {row}"
        assert ("or null" in row["required"]) == field.allow_null, f"`{path}` null? {row}"
        for limit in limits(field):
            number = f"{limit:g}" if isinstance(limit, float) else str(limit)
            found = re.search(rf"(?<![\d.]){re.escape(number)}(?![\d.])", row["limits"])
            assert found, f"`{path}`: the server's limit {number} is not in {row['limits']!r}"


def test_it_has_the_server_refuse_the_wrong_json_types_the_document_says_it_refuses():
    for path, field in heartbeat_fields():
        for wrong in WRONG_TYPES[json_type(field)]:
            if wrong is None and field.allow_null:
                continue
            try:
                field.run_validation(wrong)
            except serializers.ValidationError:
                continue
            pytest.fail(f"`{path}` accepts {wrong!r}")


def test_it_names_every_message_and_response_field():
    fields = set(HeartbeatResponseSerializer().fields)
    for message_type in MessageType.values:
        fields |= set(message_serializer(message_type)().fields)
    fields |= set(PlanStopSerializer().fields)
    plan_tasks = message_serializer(MessageType.PLAN)().fields["tasks"].child
    fields |= set(plan_tasks.fields)
    missing = sorted(fields - backticked())
    assert not missing, f"{DOC.name} never names the response field(s) {missing}"


# --- Heartbeat requests --------------------------------------------------------------------------


def test_it_validates_every_heartbeat_request_with_the_servers_serializer(eulji_map):
    assert examples("heartbeat-request")
    for block, body in examples("heartbeat-request"):
        serializer = HeartbeatSerializer(data=body, context={"site_map": eulji_map})
        assert serializer.is_valid(), f"{block}: {flatten_errors(serializer.errors)}"


def test_it_answers_every_documented_heartbeat_as_the_document_says(
    client, eulji, tokens, settings
):
    documented_tasks_create(eulji)
    token = tokens[REPLAYED_ROBOT]
    ordered = tagged(*HEARTBEAT_TAGS, "error-400")
    newest, boots, stale = None, set(), []
    for position, block in enumerate(ordered):
        if block.tag == "error-400":
            continue
        body = block.data
        status, answer = post(client, REPLAYED_ROBOT, token, body)
        if block.tag == "bad-heartbeat-request":
            following = ordered[position + 1] if position + 1 < len(ordered) else None
            assert following is not None, f"{block}: not followed by the error-400 it gets"
            assert following.tag == "error-400", f"{block}: not followed by the error-400 it gets"
            documented = following.data
            assert status == 400, f"{block}: answered {status} {answer}"
            assert answer["error"] == documented["error"], f"{following}: server says {answer}"
            assert set(answer["detail"]) == set(documented["detail"]), (
                f"{following}: server names {sorted(answer['detail'])}"
            )
            continue
        assert status == 200, f"{block}: answered {status} {answer}"
        assert set(answer) == {"server_time", "heartbeat_interval", "map_version", "messages"}
        if body.get("push"):  # the document's idle robot with its push channel open
            told = eulji.heartbeat_interval
            if not answer["messages"]:  # the idle interval, spread as the document says
                now = parse_datetime(answer["server_time"])
                idle = settings.HEARTBEAT_IDLE_INTERVAL
                replayed = Robot.objects.get(code=REPLAYED_ROBOT).pk
                told = heartbeat_interval_spread(replayed, idle, base=told, now=now)
            # server_time is to the millisecond: the interval from it, to a millisecond
            assert answer["heartbeat_interval"] == pytest.approx(told, abs=2e-3), (
                f"{block}: told {answer}"
            )
        # The document's rule for stale heartbeats: the server keeps the newest state only.
        boot, seq = body["boot_id"], body["seq"]
        if newest is not None and boot == newest["boot_id"]:
            fresh = seq > newest["seq"]
        else:
            fresh = boot not in boots
        boots.add(boot)
        if fresh:
            newest = body
        else:
            stale.append(block)
        robot = Robot.objects.select_related("waypoint").get(code=REPLAYED_ROBOT)
        kept = (robot.boot_id, robot.seq, robot.status, robot.waypoint.code)
        state = newest["state"]
        expected = (newest["boot_id"], newest["seq"], state["status"], state["waypoint"])
        assert kept == expected, f"{block}: the server kept {kept}"
    assert stale, f"{DOC.name} shows no stale heartbeat"


def test_it_reproduces_the_documented_refusals_of_tokens_and_sizes(client, tokens, settings):
    other = next(code for code in tokens if code != REPLAYED_ROBOT)
    too_big = "{" + " " * settings.HEARTBEAT_MAX_BYTES + "}"
    answers = {
        "error-401": post(client, REPLAYED_ROBOT, "not-a-token", {}),
        "error-403": post(client, other, tokens[REPLAYED_ROBOT], {}),
        "error-413": post(client, REPLAYED_ROBOT, tokens[REPLAYED_ROBOT], too_big),
    }
    for tag, (status, answer) in answers.items():
        assert status == int(tag.removeprefix("error-")), (tag, status, answer)
        for block, documented in examples(tag):
            assert set(documented) == {"error", "detail"}, f"{block}: {documented}"
            assert documented["error"] == answer["error"], f"{block}: server says {answer}"
            assert isinstance(documented["detail"], str), f"{block}: detail is a sentence"


def test_it_gives_every_400_the_servers_shape_and_field_paths():
    paths = heartbeat_path_pattern()
    for block, documented in examples("error-400"):
        assert set(documented) == {"error", "detail"}, f"{block}: {documented}"
        assert documented["error"] in {"invalid", "invalid_json"}, str(block)
        detail = documented["detail"]
        assert isinstance(detail, dict), f"{block}: detail must name fields"
        assert detail, f"{block}: detail must name fields"
        for path, reasons in detail.items():
            assert paths.fullmatch(path), f"{block}: {path!r} is no field of a heartbeat"
            assert isinstance(reasons, list), f"{block}: {path}: {reasons!r}"
            assert reasons, f"{block}: {path}: no reason"
            assert all(isinstance(reason, str) and reason for reason in reasons), str(block)
        if documented["error"] == "invalid_json":
            assert set(detail) == {"body"}, f"{block}: invalid JSON is about the body"
    assert flatten_errors({"events": {3: {"task": ["x"]}}}) == {"events[3].task": ["x"]}


# --- Heartbeat responses and messages ------------------------------------------------------------


def test_it_validates_every_response_with_the_servers_documentation_serializer(eulji):
    fields = HeartbeatResponseSerializer().fields
    for block, answer in examples("heartbeat-response"):
        assert set(answer) == set(fields), f"{block}: fields {sorted(answer)}"
        fields["server_time"].run_validation(answer["server_time"])
        assert answer["server_time"].endswith("Z"), f"{block}: server_time is sent in UTC"
        fields["heartbeat_interval"].run_validation(answer["heartbeat_interval"])
        assert answer["heartbeat_interval"] == eulji.heartbeat_interval, str(block)
        fields["map_version"].run_validation(answer["map_version"])
        assert answer["map_version"] == eulji.map_version, str(block)
        assert isinstance(answer["messages"], list), str(block)


def test_it_validates_every_message_with_the_servers_documentation_serializers(eulji, eulji_map):
    router = router_for(eulji)
    messages = all_messages()
    assert {message["type"] for _, message in messages} == set(MessageType.values)
    for block in tagged(*MESSAGE_TAGS):
        assert block.data["type"] == MESSAGE_TAGS[block.tag], f"{block}: a {block.data['type']}"
    for where, message in messages:
        assert BoardMessage.pk_from_public_id(message["id"]) is not None, f"{where}: id"
        serializer = message_serializer(message["type"])(data=message)
        serializer.is_valid()
        errors = flatten_errors(serializer.errors) if serializer.errors else {}
        if message["type"] == MessageType.PLAN:
            dock_stops_checked(where, message, eulji_map)
            plan_checked(where, message, eulji_map, router)
        assert not errors, f"{where}: {errors}"
        if "resource" in message:
            resource = message["resource"]
            assert resource in eulji_map.resources, f"{where}: no resource {resource}"
        if "to_floor" in message:
            floor = message["to_floor"]
            assert eulji_map.resources[message["resource"]].is_elevator, where
            assert eulji_map.serves_floor(message["resource"], floor), f"{where}: {floor}"


def dock_stops_checked(where, plan, eulji_map) -> None:
    """A dock stop has no task and no stop, and is at a dock, or at a refuge point and first
    (a fire alarm's); a task stop has both."""
    for n, stop in enumerate(plan["stops"]):
        if stop["action"] == DOCK:
            assert {"action", "waypoint"} <= set(stop) <= {"action", "waypoint", "via", "charge"}
            assert stop.get("charge", True) is True, f"{where}: stops[{n}].charge"
            kind = eulji_map.waypoints[stop["waypoint"]].kind
            assert kind == DOCK or (kind == REFUGE and n == 0), f"{where}: stops[{n}]"
        else:
            assert {"task", "stop"} <= set(stop), f"{where}: stops[{n}]"


def plan_checked(where, plan, eulji_map, router) -> None:
    task_stops = [stop for stop in plan["stops"] if stop["action"] != DOCK]
    assert {stop["task"] for stop in task_stops} == set(plan["tasks"]), f"{where}: tasks"
    previous = None
    for n, stop in enumerate(plan["stops"]):
        waypoint = eulji_map.waypoints.get(stop["waypoint"])
        assert waypoint is not None, f"{where}: stops[{n}]: no waypoint {stop['waypoint']}"
        if stop["action"] != DOCK:
            assert waypoint.kind == "station", f"{where}: stops[{n}] is not at a station"
        via = stop.get("via", [])
        assert "via" not in stop or via, f"{where}: stops[{n}]: an empty via is left out"
        lobbies = {code for stops in eulji_map.elevator_stops.values() for code in stops.values()}
        assert set(via) <= lobbies, f"{where}: stops[{n}].via {via}: not elevator lobbies"
        assert len(via) % 2 == 0, f"{where}: stops[{n}].via {via}: not in pairs"
        if previous is not None:
            expected = router.leg(previous, stop["waypoint"]).via
            assert via == expected, f"{where}: stops[{n}].via is {expected} on the map"
        previous = stop["waypoint"]


def test_it_documents_exactly_the_fields_the_server_sends(
    client, eulji, tokens, admin_user, settings
):
    settings.ALLOCATE_ON_REQUEST = True  # the delivery goes to R3 within its request
    sent = server_messages(client, eulji, tokens, admin_user)
    assert {message["type"] for message in sent} == set(MessageType.values)
    documented = [message for _, message in all_messages()]
    for kinds in (fields_by_kind(sent), fields_by_kind(documented)):
        assert kinds.keys() >= {"plan", "task stop", "dock stop", "plan task"}
    assert fields_by_kind(documented) == fields_by_kind(sent)


def fields_by_kind(messages: list[dict]) -> dict[str, set[str]]:
    """The fields seen in each kind of message, plan stop (task or dock) and plan task."""
    kinds: dict[str, set[str]] = {}
    for message in messages:
        kinds.setdefault(message["type"], set()).update(message)
        for stop in message.get("stops", []):
            kind = "dock stop" if stop["action"] == DOCK else "task stop"
            kinds.setdefault(kind, set()).update(stop)
        for task in message.get("tasks", {}).values():
            kinds.setdefault("plan task", set()).update(task)
    return kinds


def server_messages(client, eulji, tokens, staff) -> list[dict]:
    """Board messages of every type, as the server really sends them: R3 is given a delivery
    across floors, does it and is sent to its dock; takes the elevator, for which R4 queues;
    and is paused by an operator; R4, low on battery, is sent to charge; R3 gets into the car
    and a fire alarm tells it to get out."""
    received: list[dict] = []
    seqs: dict[str, int] = {}

    def beat(code, waypoint, status="idle", battery=0.9, **fields):
        seqs[code] = seqs.get(code, 0) + 1
        state = {
            "status": status,
            "floor": waypoint.split("-")[0],
            "waypoint": waypoint,
            "battery": battery,
            "load": 0,
            "plan_version": 0,
        }
        body = {"boot_id": f"boot-{code}", "seq": seqs[code], "state": state, **fields}
        status_code, answer = post(client, code, tokens[code], body)
        assert status_code == 200, answer
        received.extend(answer["messages"])
        return answer["messages"]

    def event(n, type, **fields):
        return {"id": f"e-{n}", "type": type, **fields}

    beat("R3", "15F-DOCK-3", status="charging")
    client.force_login(staff)
    order = {
        "sender": "Ward 6A",
        "receiver": "Laboratory",
        "contents": "Blood samples",
        "priority": "urgent",
        "pickups": ["6F-WARD-A"],
        "dropoffs": ["2F-LAB-DROP"],
        "secure": True,  # so the plan's task carries `secure` too
    }
    created = client.post("/api/v1/tasks/", data=order, content_type="application/json")
    assert created.status_code == 201, created.content
    client.logout()
    code = created.json()["code"]
    plans = [m for m in beat("R3", "15F-DOCK-3") if m["type"] == MessageType.PLAN]
    assert plans, f"{code} was not given to R3 at once"
    loaded = event(1, "loaded", task=code, stop=0)
    beat("R3", "6F-WARD-A", acks=[plans[-1]["id"]], events=[loaded])
    done = [event(2, "unloaded", task=code, stop=1), event(3, "task_completed", task=code)]
    beat("R3", "2F-LAB-DROP", events=done)
    ride = {"id": "q-1", "type": "acquire", "resource": "ELEV-A", "to_floor": "15F"}
    beat("R3", "2F-ELEV-A-WAIT", requests=[ride])
    wait = {"id": "q-2", "type": "acquire", "resource": "ELEV-A", "to_floor": "2F"}
    beat("R4", "15F-ELEV-A-WAIT", requests=[wait])
    # The simulated car comes to R3's floor and opens its doors there: R3 is told.
    lift = Device.objects.get(resource__code="ELEV-A")
    sim_step(device=lift, now=timezone.now() + timedelta(minutes=5))
    beat("R3", "2F-ELEV-A-WAIT", status="waiting_resource")
    # The lift is taken out of service and back: both robots with a lease on it are told.
    elevator = Resource.objects.get(site=eulji, code="ELEV-A")
    resource_take_out_of_service(resource=elevator, reason="maintenance", actor=staff)
    beat("R4", "15F-ELEV-A-WAIT", status="waiting_resource")
    resource_return_to_service(resource=elevator, actor=staff)
    beat("R4", "15F-ELEV-A-WAIT", status="waiting_resource")
    robot_action(robot=Robot.objects.get(code="R3"), action="pause", by=staff)
    beat("R3", "2F-ELEV-A-WAIT", status="waiting_resource")
    beat("R4", "15F-ELEV-A-WAIT", battery=0.1)  # low, nothing on board: sent to charge
    # R3 gets into the car; a fire alarm starts: the car opens where it is and R3 is told
    # to get out there.
    beat(
        "R3",
        "2F-ELEV-A-WAIT",
        status="in_resource",
        events=[event(4, "resource_entered", resource="ELEV-A")],
    )
    emergency_start(site=eulji, floors=["2F"], reason="drill", via="api", by=staff)
    beat("R3", "2F-ELEV-A-WAIT", status="in_resource")
    return received


def test_it_shapes_every_wake_as_the_push_channel_sends_it():
    assert examples("push-wake")
    for block, wake in examples("push-wake"):
        assert set(wake) == {"type", "message"}, f"{block}: {wake}"
        assert wake["type"] == "wake", str(block)
        assert re.fullmatch(r"m-\d+", wake["message"]), f"{block}: {wake['message']!r}"
        assert BoardMessage.pk_from_public_id(wake["message"]) is not None, str(block)


# --- Secure deliveries ----------------------------------------------------------------------------


def test_its_pin_hashes_open_for_the_pins_it_states_and_no_other():
    """The worked secure delivery states its PINs; its plan's hashes are theirs, checked as the
    server makes them and as the reference client checks them."""
    stated = re.findall(r"the PINs `(\d{6,12})` and `(\d{6,12})`", doc_text())
    assert stated, f"{DOC.name} states no PINs for its secure example"
    pins = dict(zip(("T-0045", "T-0046"), stated[0], strict=True))
    secure = {
        code: details["secure"]
        for code, task in task_stops_documented().items()
        if "secure" in (details := task["details"])
    }
    assert set(secure) == set(pins)
    for code, pin in pins.items():
        wire = secure[code]["pin"]
        hashed = PinHash(salt=wire["salt"], iterations=wire["iterations"], hash=wire["hash"])
        assert wire["algorithm"] == ALGORITHM
        assert wire["iterations"] == ITERATIONS
        assert wire["digits"] == len(pin) == settings.SECURE_PIN_DIGITS
        assert pin_matches(pin, hashed), f"{code}: {pin} does not match its documented hash"
        assert pin_check(pin, secure[code]), f"{code}: the reference client refuses {pin}"
        assert not pin_check("0" * len(pin), secure[code])


def test_its_badge_hashes_open_for_the_badge_it_states_and_name_its_holder():
    """The worked secure delivery states a nurse's badge; the plan's hash is of it, as the
    server makes it and as the reference client checks it, and never carries the badge."""
    stated = re.findall(r"her badge `([0-9A-F:]+)` to", doc_text())
    assert stated, f"{DOC.name} states no badge for its secure example"
    [badge] = stated
    secure = task_stops_documented()["T-0045"]["details"]["secure"]
    [entry] = secure["badges"]
    hashed = BadgeHash(salt=entry["salt"], iterations=entry["iterations"], hash=entry["hash"])
    assert badge_matches(badge, hashed)
    assert badge_check(badge, secure) == entry["holder"] == "park"
    assert badge_check(badge.lower(), secure) is None
    assert badge not in json.dumps(secure)
