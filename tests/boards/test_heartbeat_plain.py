"""The plain heartbeat's shortcut (boards.serializers.heartbeat_plain) gives what the
serializer gives, or leaves the body to it: generated bodies, valid and not."""

import copy
import math

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from rest_framework.exceptions import ValidationError

from boards.serializers import HeartbeatSerializer, heartbeat_plain, heartbeat_validate
from robots.mapcache import site_map
from tests import factories

pytestmark = pytest.mark.django_db

ABSENT = object()  # the key left out of the body
EXAMPLES = settings(
    max_examples=600, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)

texts = st.sampled_from(
    ["1F", "2F", "1F-DOCK-1", "9F", "", " 1F", "1F ", "1F\x00", "１F", "a" * 65, "a" * 201, "\t"]
    + ["m-1", " m-1", "m-1\n", "m\x00", "m\x7f", "boot 2"]
)
oddities = st.sampled_from([ABSENT, None, True, False, [], {}, "1", 1.5, -1, 2**63, 10**400])
numbers = st.one_of(
    st.integers(min_value=-(2**60), max_value=2**60),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, 0.0, 1.0, 2**53, 2**53 + 1, -(2**53) - 1, 32767, 32768, 2**31]),
)
anything = st.one_of(oddities, texts, numbers)


PATHS = [
    *("boot_id", "seq", "sent_at", "state", "events", "acks", "requests", "push"),
    *(f"state.{name}" for name in ("status", "floor", "waypoint", "battery", "load")),
    *(f"state.{name}" for name in ("plan_version", "errors", "x", "y", "heading")),
]


@st.composite
def bodies(draw, floors, waypoints):
    """A valid body, or one with up to three of its values replaced by others, valid or not."""
    floor_of = draw(st.sampled_from(waypoints))
    state = {
        "status": draw(st.sampled_from(["idle", "moving", "charging"])),
        "floor": floor_of[1],
        "waypoint": draw(st.sampled_from([floor_of[0], None, ABSENT])),
        "battery": draw(st.one_of(st.floats(min_value=0, max_value=1), st.sampled_from([0, 1]))),
        "load": draw(st.integers(min_value=0, max_value=32767)),
        "plan_version": draw(st.integers(min_value=0, max_value=2**31 - 1)),
        "errors": draw(st.sampled_from([ABSENT, [], ["E-STOP"], ["motor hot", ""]])),
        **{
            name: draw(st.one_of(st.floats(-1e6, 1e6), st.integers(-5, 5), oddities))
            for name in ("x", "y", "heading")
        },
    }
    body = {
        "boot_id": draw(st.sampled_from(["boot-1", "b" * 64])),
        "seq": draw(st.integers(min_value=0, max_value=2**63 - 1)),
        "sent_at": draw(st.sampled_from([ABSENT, "2026-11-22T09:14:03.120Z"])),
        "state": state,
        "events": draw(st.sampled_from([ABSENT, []])),
        "acks": draw(st.sampled_from([ABSENT, [], ["m-12"], ["m-12", "m-13"]])),
        "requests": draw(st.sampled_from([ABSENT, []])),
        "push": draw(st.sampled_from([ABSENT, True, False])),
    }
    floor_codes = st.sampled_from(floors)
    replacements = st.one_of(
        anything,
        floor_codes,
        st.sampled_from([w for w, _ in waypoints]),
        st.lists(texts, min_size=1, max_size=2),  # acks, errors
    )
    for path in draw(st.lists(st.sampled_from(PATHS), max_size=3)):
        *parent, key = path.split(".")
        target = body["state"] if parent and isinstance(body["state"], dict) else body
        target[key] = _fresh(
            draw(
                st.one_of(
                    replacements,
                    st.sampled_from(
                        [[{"id": "e1", "type": "loaded"}], ["m-1", ""], ["m-1", 2], [" "], {}]
                    ),
                    st.sampled_from(["2026-11-22", "x", "2026-11-22T09:14:03+09:00", "Idle"]),
                )
            )
        )
    return _without_absent(body)


def _fresh(value):
    """A copy of a drawn value: sampled_from hands out the same {} or [] every time, so
    one changed in place (state replaced by {}, then state.x set) carries over to the next
    example, or loops into itself (state.events set to that same {})."""
    return copy.deepcopy(value, memo={id(ABSENT): ABSENT})


def _without_absent(value):
    if isinstance(value, dict):
        return {k: _without_absent(v) for k, v in value.items() if v is not ABSENT}
    return value


def typed(value):
    """The value with every number's type kept (1 == 1.0 == True otherwise)."""
    if isinstance(value, dict):
        return {key: typed(item) for key, item in value.items()}
    if isinstance(value, list):
        return [typed(item) for item in value]
    return (type(value).__name__, value)


@pytest.fixture
def the_map(site):
    return site_map(site)


@EXAMPLES
@given(data=st.data())
@example(data=None)
def test_the_shortcut_agrees_with_the_serializer_or_leaves_the_body_to_it(the_map, data):
    floors = sorted(the_map.floors)
    waypoints = sorted((code, point.floor) for code, point in the_map.waypoints.items())
    # data None: the robots' everyday heartbeat, which the shortcut takes.
    body = factories.heartbeat_body(7) if data is None else data.draw(bodies(floors, waypoints))
    serializer = HeartbeatSerializer(data=body, context={"site_map": the_map})

    plain = heartbeat_plain(body, the_map)

    if data is None:
        assert plain is not None
    if plain is not None:
        assert serializer.is_valid(), serializer.errors
        assert typed(plain) == typed(dict(serializer.validated_data))
    else:
        assert not serializer.is_valid() or _outside_the_shortcut(body)


def _outside_the_shortcut(body) -> bool:
    """A valid body the shortcut leaves to the serializer, as its docstring says."""
    state = body["state"]
    codes = [state["floor"], state.get("waypoint") or "-"]
    texts = [body["boot_id"], *codes, *body.get("acks", []), *state.get("errors", [])]
    numbers = [state.get(name) for name in ("battery", "x", "y", "heading")]
    return (
        bool(body.get("events") or body.get("requests"))
        or any(
            not (text.isascii() and text.isprintable() and text.strip() == text) for text in texts
        )
        or "" in texts
        or any(type(number) is int and abs(number) > 2**53 for number in numbers)
    )


EDGES = [
    *[("boot_id", value) for value in (" boot-1", "boot-1\t", "b\x00", "", "b" * 65)],
    *[("acks", value) for value in (["m-1 "], ["m\x00"], [""], ["m-1", 7], ["a" * 65])],
    *[("state.errors", value) for value in ([" hot"], ["\x00"], [""], ["a" * 201])],
    *[("state.floor", value) for value in (" 1F", "2F", "9F")],  # 2F: its dock is on 1F
    *[("state.waypoint", value) for value in ("1F-DOCK-1 ", None, "")],
    *[("state.battery", value) for value in (1, 0, 1.5, -0.0, 2**60, True)],
    *[("state.heading", value) for value in (2**53, 2**53 + 1, 10**400, 3, None, 1e308, True)],
    *[("state.load", value) for value in (-1, 32768, 2.0)],
    *[("state.status", value) for value in ("unknown", "Idle", " idle")],
    *[("seq", value) for value in (-1, 2**63, 2**63 - 1)],
    *[("events", value) for value in ([], None, [{"id": "e1", "type": "loaded"}])],
    *[
        ("requests", value)
        for value in ([], {}, [{"id": "r1", "type": "acquire", "resource": "X"}])
    ],
    *[("sent_at", value) for value in ("2026-11-22T09:14:03+09:00", "2026-11-22", 5)],
]


@pytest.mark.parametrize(("path", "value"), EDGES, ids=[f"{p}={v!r}" for p, v in EDGES])
def test_at_each_edge_the_shortcut_agrees_or_leaves_the_body(the_map, path, value):
    body = factories.heartbeat_body(7)
    *parent, key = path.split(".")
    (body["state"] if parent else body)[key] = value
    serializer = HeartbeatSerializer(data=body, context={"site_map": the_map})

    plain = heartbeat_plain(body, the_map)

    if plain is not None:
        assert serializer.is_valid(), serializer.errors
        assert typed(plain) == typed(dict(serializer.validated_data))
    else:
        assert not serializer.is_valid() or _outside_the_shortcut(body)


def test_a_body_the_shortcut_leaves_is_still_refused_by_name(the_map):
    body = factories.heartbeat_body(1, state={"battery": math.inf})

    with pytest.raises(ValidationError) as refused:
        heartbeat_validate(body, the_map)

    assert "battery" in str(refused.value.detail["state"])
