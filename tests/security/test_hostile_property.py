"""Property: whatever body a robot or a hospital system sends, the answer is never a 5xx, and a
refused body (4xx, in the documented error shape) changes nothing. Generated bodies are sent
over real HTTP to the live server."""

import json

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from boards.models import BoardMessage, RobotEvent
from scheduling.models import Task, TaskTransition
from tests import factories

EXAMPLES = settings(
    max_examples=100,
    deadline=None,
    suppress_health_check=[
        HealthCheck.function_scoped_fixture,
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
    ],
)

# Any code point, lone surrogates and NUL included (st.text() leaves surrogates out).
any_char = st.characters(min_codepoint=0, max_codepoint=0x10FFFF, exclude_categories=())
nasty_text = st.one_of(
    st.text(any_char, max_size=40),
    st.sampled_from(
        ["T-²", "T-" + "9" * 25, "m-²", "m-" + "9" * 40, "\ud800", "a\x00b", "1F", "idle", "T-0001"]
    ),
)
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**40), max_value=10**40),
    st.sampled_from([2**63, -(2**63) - 1, 10**400, 2**31]),
    st.floats(allow_nan=True, allow_infinity=True),
    nasty_text,
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(nasty_text, inner, max_size=4)
    ),
    max_leaves=12,
)
# Raw fragments json.dumps cannot produce: deep nesting, numbers beyond float, bad syntax.
raw_fragments = st.sampled_from(
    [
        "[" * 3000,
        "[" * 40 + "]" * 40,
        "1e400",
        "-1e400",
        "1" + "0" * 400,
        "NaN",
        "0x10",
        '"\\ud800"',
    ]
)


@st.composite
def mutations(draw, paths):
    """(path, JSON text) pairs to splice into a valid body."""
    path = draw(st.sampled_from(paths))
    # Three in four values are the known-hostile fragments.
    generated = st.one_of(scalars.map(json.dumps), values.map(json.dumps))
    fragment = draw(st.one_of(raw_fragments, raw_fragments, raw_fragments, generated))
    return path, fragment


def splice(body: dict, changes) -> bytes:
    """`body` as JSON with each dotted path ("state.battery") replaced by a raw JSON fragment."""
    body = json.loads(json.dumps(body))
    for n, (path, _) in enumerate(changes):
        *parents, last = [int(key) if key.isdigit() else key for key in path.split(".")]
        target = body
        for key in parents:
            if not isinstance(target, dict | list):
                break  # an earlier change replaced a parent of this path
            target = target[key]
        else:
            if isinstance(target, dict | list):
                target[last] = f"@@{n}@@"
    text = json.dumps(body)
    for n, (_, fragment) in enumerate(changes):
        text = text.replace(f'"@@{n}@@"', fragment)
    return text.encode()


def hostile_bodies(base: dict, paths: list[str]):
    whole = st.one_of(
        raw_fragments.map(str.encode),
        st.binary(max_size=64),
        values.map(lambda value: json.dumps(value).encode()),
    )
    spliced = st.lists(mutations(paths), min_size=1, max_size=4).map(lambda c: splice(base, c))
    return st.one_of(spliced, spliced, whole)


def with_examples(bodies: list[bytes]):
    """Always try these bodies too (the cases issue 15 found), besides the generated ones."""

    def decorate(test):
        for raw in bodies:
            test = example(raw=raw)(test)
        return test

    return decorate


def assert_refused_or_fine(response):
    assert response.status_code < 500, response.text
    if response.status_code >= 400:
        body = response.json()
        assert set(body) == {"error", "detail"}, body
        assert isinstance(body["error"], str)
    return response.status_code < 400


HEARTBEAT = factories.heartbeat_body(
    1,
    events=[{"id": "e-1", "type": "task_received", "task": "T-0001"}],
    acks=["m-1"],
)
KNOWN_HEARTBEATS = [
    splice(HEARTBEAT, [(path, fragment)])
    for path, fragment in [
        ("state.battery", "1" + "0" * 400),
        ("events.0.task", '"T-\\u00b2"'),
        ("events.0.task", '"T-' + "9" * 25 + '"'),
        ("acks.0", '"m-\\u00b2"'),
        ("acks.0", '"m-' + "9" * 40 + '"'),
        ("state.status", '"\\ud800"'),
        ("state", "[" * 3000),
    ]
]
HEARTBEAT_PATHS = [
    "boot_id",
    "seq",
    "sent_at",
    "state",
    "state.status",
    "state.floor",
    "state.waypoint",
    "state.x",
    "state.battery",
    "state.load",
    "state.plan_version",
    "state.errors",
    "events",
    "events.0",
    "events.0.id",
    "events.0.type",
    "events.0.task",
    "events.0.stop",
    "events.0.at",
    "acks",
    "acks.0",
    "requests",
    "extra",
]


def robot_snapshot(robot):
    robot.refresh_from_db()
    return (
        robot.seq,
        robot.last_seen_at,
        robot.status,
        robot.battery,
        RobotEvent.objects.count(),
        BoardMessage.objects.filter(acked_at__isnull=False).count(),
    )


@pytest.mark.slow
def test_no_heartbeat_body_gives_a_5xx_or_a_partial_write(robot_http, robot):
    @EXAMPLES
    @given(raw=hostile_bodies(HEARTBEAT, HEARTBEAT_PATHS))
    @with_examples(KNOWN_HEARTBEATS)
    def check(raw):
        before = robot_snapshot(robot)
        if not assert_refused_or_fine(robot_http.post(raw=raw)):
            assert robot_snapshot(robot) == before

    check()


TASK = {
    "sender": "Pharmacy",
    "receiver": "Nurse Kim",
    "contents": "Insulin",
    "priority": "urgent",
    "requested_time": "2099-01-01T08:00:00Z",
    "pickups": ["1F-PHARM"],
    "dropoffs": ["3F-WARD"],
    "repeat": {"every_minutes": 60, "from": "08:00", "until": "12:00"},
}
KNOWN_TASKS = [
    b"[" * 3000,
    splice(TASK, [("priority", '"\\ud800"')]),
    splice(TASK, [("site", '"\\u0000"')]),
    json.dumps({**TASK, "contents": "x" * (3 * 1024 * 1024)}).encode(),
]
TASK_PATHS = [
    "sender",
    "receiver",
    "contents",
    "priority",
    "requested_time",
    "pickups",
    "pickups.0",
    "dropoffs",
    "dropoffs.0",
    "repeat",
    "repeat.every_minutes",
    "repeat.from",
    "site",
]


@pytest.mark.slow
def test_no_task_request_gives_a_5xx_or_a_partial_write(api_http, site):
    @EXAMPLES
    @given(raw=hostile_bodies(TASK, TASK_PATHS))
    @with_examples(KNOWN_TASKS)
    def check(raw):
        before = (Task.objects.count(), TaskTransition.objects.count())
        if not assert_refused_or_fine(api_http.post("/api/v1/tasks/", raw=raw)):
            assert (Task.objects.count(), TaskTransition.objects.count()) == before

    check()
