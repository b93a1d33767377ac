"""Builders shared by the tests. Sites are built through the real site loader."""

import copy
import itertools
import uuid

from django.contrib.auth import get_user_model
from django.contrib.auth.models import Group
from django.db import transaction
from django.utils import timezone

from boards.serializers import HeartbeatSerializer
from boards.services import heartbeat_apply
from core.access import GROUPS
from core.overload import heartbeat_interval_spread
from hospital_delivery.models import ApiToken
from resources.models import Lease
from robots.mapcache import floor_code_by_id, site_map
from robots.models import Robot, Site, SiteMembership
from robots.services import robot_lock, robot_token_issue
from robots.sitefile import site_load

# A small three-floor hospital with one of each resource kind, and a corridor of capacity 2 (and
# a fourth floor out of the elevator's reach).
TINY_SITE = {
    "site": "tiny",
    "name": "Tiny test hospital",
    "robot_speed": 1.0,
    "heartbeat_interval": 1.0,
    "ack_timeout": 30,
    "offline_timeout": 300,
    "floors": [
        {
            "code": "1F",
            "level": 1,
            "waypoints": [
                {"code": "1F-DOCK-1", "x": 0, "y": 0, "kind": "dock", "name": "Dock 1"},
                {"code": "1F-DOCK-2", "x": 0, "y": 5, "kind": "dock", "name": "Dock 2"},
                {"code": "1F-HALL", "x": 10, "y": 0},
                {"code": "1F-PHARM", "x": 10, "y": 10, "kind": "station", "name": "Pharmacy"},
                {"code": "1F-ELEV-WAIT", "x": 20, "y": 0, "kind": "resource_wait"},
            ],
            "edges": [
                ["1F-DOCK-1", "1F-HALL"],
                ["1F-DOCK-2", "1F-HALL"],
                ["1F-HALL", "1F-PHARM"],
                ["1F-HALL", "1F-ELEV-WAIT"],
            ],
        },
        {
            "code": "2F",
            "level": 2,
            "waypoints": [
                {"code": "2F-ELEV-WAIT", "x": 20, "y": 0, "kind": "resource_wait"},
                {"code": "2F-LAB-DOOR-N", "x": 20, "y": 10, "kind": "resource_wait"},
                {"code": "2F-LAB-DOOR-S", "x": 20, "y": 12, "kind": "resource_wait"},
                {"code": "2F-LAB", "x": 20, "y": 30, "kind": "station", "name": "Laboratory"},
            ],
            "edges": [
                ["2F-ELEV-WAIT", "2F-LAB-DOOR-N"],
                ["2F-LAB-DOOR-N", "2F-LAB-DOOR-S"],
                ["2F-LAB-DOOR-S", "2F-LAB"],
            ],
        },
        {
            "code": "3F",
            "level": 3,
            "waypoints": [
                {"code": "3F-ELEV-WAIT", "x": 20, "y": 0, "kind": "resource_wait"},
                {"code": "3F-CORR-W", "x": 30, "y": 0, "kind": "resource_wait"},
                {"code": "3F-CORR-MID", "x": 40, "y": 0},
                {"code": "3F-CORR-E", "x": 50, "y": 0, "kind": "resource_wait"},
                {"code": "3F-WARD", "x": 60, "y": 0, "kind": "station", "name": "Ward 3"},
            ],
            "edges": [
                ["3F-ELEV-WAIT", "3F-CORR-W"],
                ["3F-CORR-W", "3F-CORR-MID"],
                ["3F-CORR-MID", "3F-CORR-E"],
                ["3F-CORR-E", "3F-WARD"],
            ],
        },
        # A floor the elevator does not serve (nothing can reach it): rides there are refused.
        {"code": "4F", "level": 4, "waypoints": [{"code": "4F-HALL", "x": 0, "y": 0}]},
    ],
    "resources": [
        {
            "code": "ELEV",
            "kind": "elevator",
            "capacity": 1,
            "stops": {"1F": "1F-ELEV-WAIT", "2F": "2F-ELEV-WAIT", "3F": "3F-ELEV-WAIT"},
            "seconds_per_floor": 2.5,
            "overhead_seconds": 30,
        },
        {
            "code": "DOOR-2F",
            "kind": "door",
            "capacity": 1,
            "waiting": ["2F-LAB-DOOR-N", "2F-LAB-DOOR-S"],
            "guards": [["2F-LAB-DOOR-N", "2F-LAB-DOOR-S"]],
        },
        {
            "code": "CORR-3F",
            "kind": "corridor",
            "capacity": 2,
            "waiting": ["3F-CORR-W", "3F-CORR-E"],
            "guards": [["3F-CORR-W", "3F-CORR-MID"], ["3F-CORR-MID", "3F-CORR-E"]],
        },
    ],
    "robots": [],
}

_robot_numbers = itertools.count(1)


def tiny_site_with_refuge() -> dict:
    """The tiny site with a refuge point on 1F, off its hall (a fire alarm's)."""
    data = copy.deepcopy(TINY_SITE)
    first = data["floors"][0]
    first["waypoints"].append(
        {"code": "1F-REFUGE", "x": 10, "y": -8, "kind": "refuge", "name": "1F refuge"}
    )
    first["edges"].append(["1F-HALL", "1F-REFUGE"])
    return data


def site_create(*, members=None, **overrides) -> Site:
    """The tiny site; every nurse and operator made so far is a member of it unless `members`
    names who is."""
    data = copy.deepcopy(TINY_SITE)
    data.update(overrides)
    site = site_load(data=data)
    if members is None:
        members = get_user_model().objects.filter(groups__name__in=GROUPS).distinct()
    SiteMembership.objects.bulk_create(
        [SiteMembership(user=user, site=site) for user in members], ignore_conflicts=True
    )
    return site


def robot_create(site: Site, code: str | None = None, **fields) -> Robot:
    """A robot docked at the site's first dock; its plain token is on robot.token."""
    fields.setdefault("dock", site.waypoints.filter(kind="dock").order_by("code").first())
    fields.setdefault("capacity", 4)
    robot = Robot.objects.create(site=site, code=code or f"R{next(_robot_numbers)}", **fields)
    robot.token = robot_token_issue(robot=robot)
    return robot


def staff_create(username: str = "operator", **fields):
    fields.setdefault("is_staff", True)
    user = get_user_model().objects.create_user(username=username, password="pw-12345!", **fields)
    user.api_token_plain = ApiToken.issue(user)
    return user


PASSWORD = "pw-12345!"


def user_create(username: str, *groups: str, sites=None, **fields):
    """A user of the pages in `groups` ("nurse", "operator"; none: may not use them), a member
    of `sites` (default: every site made so far; site_create adds them to later ones).

    The groups come from a data migration, but transactional tests flush them: made if missing.
    """
    user = get_user_model().objects.create_user(username=username, password=PASSWORD, **fields)
    for name in groups:
        user.groups.add(Group.objects.get_or_create(name=name)[0])
    for site in Site.objects.all() if sites is None else sites:
        SiteMembership.objects.create(user=user, site=site)
    return user


def heartbeat_body(seq: int = 1, *, boot_id: str = "boot-1", **overrides) -> dict:
    state = {
        "status": "idle",
        "floor": "1F",
        "waypoint": "1F-DOCK-1",
        "x": 0.0,
        "y": 0.0,
        "heading": 0.0,
        "battery": 0.9,
        "load": 0,
        "plan_version": 0,
        "errors": [],
    }
    given = overrides.pop("state", {})
    if given.get("floor", "1F") != "1F" and "waypoint" not in given:
        state["waypoint"] = None  # the default waypoint is on 1F (protocol: on state.floor)
    state.update(given)
    body = {
        "boot_id": boot_id,
        "seq": seq,
        "sent_at": "2026-11-22T09:14:03.120Z",
        "state": state,
        "events": [],
        "acks": [],
        "requests": [],
    }
    body.update(overrides)
    return body


def event_id() -> str:
    return f"e-{uuid.uuid4().hex[:12]}"


# --- The resource controller, driven in-process through the real heartbeat service ------------
# (resources.leases has no acquire/release/enter of its own: robots ask through heartbeats.)

_lease_seqs = itertools.count(1)


def heartbeat_apply_now(robot: Robot, *, now, requests=(), events=()) -> None:
    """Apply one heartbeat of `robot` at `now` carrying `requests` and `events`, as the heartbeat
    view does (validated, robot row locked, one transaction); it reports the robot idle where it
    last was (its floor, else 1F)."""
    with transaction.atomic():
        locked = robot_lock(robot.pk)
        floor = floor_code_by_id(locked.site, locked.floor_id) or "1F"
        body = heartbeat_body(
            next(_lease_seqs),
            boot_id="leases-in-process",
            state={"floor": floor, "waypoint": None, "plan_version": locked.plan_version},
            requests=list(requests),
            events=list(events),
        )
        serializer = HeartbeatSerializer(data=body, context={"site_map": site_map(locked.site)})
        serializer.is_valid(raise_exception=True)
        heartbeat_apply(robot=locked, heartbeat=serializer.validated_data, now=now)


def lease_acquire(*, robot, resource, request_id: str, to_floor=None, now=None):
    """The robot's acquire request; returns its lease on the resource (new or existing)."""
    request = {"id": request_id, "type": "acquire", "resource": resource.code}
    if to_floor:
        request["to_floor"] = to_floor
    heartbeat_apply_now(robot, now=now or timezone.now(), requests=[request])
    return _latest_lease(robot, resource)


def lease_enter(*, robot, resource, now=None):
    """The robot's resource_entered event; returns its lease."""
    event = {"id": event_id(), "type": "resource_entered", "resource": resource.code}
    heartbeat_apply_now(robot, now=now or timezone.now(), events=[event])
    return _latest_lease(robot, resource)


def lease_release(*, robot, resource, now=None):
    """The robot's release request; returns the lease it ended."""
    request = {"id": f"q-{uuid.uuid4().hex[:12]}", "type": "release", "resource": resource.code}
    heartbeat_apply_now(robot, now=now or timezone.now(), requests=[request])
    return _latest_lease(robot, resource)


def _latest_lease(robot, resource):
    return Lease.objects.filter(robot=robot, resource=resource).order_by("-pk").first()


def interval_told(robot: Robot, interval: float) -> float:
    """What `robot` was told at its last heartbeat for `interval`: spread over the robots when
    longer than its site's (core.overload.heartbeat_interval_spread), from when it was seen."""
    robot.refresh_from_db()
    base = robot.site.heartbeat_interval
    return heartbeat_interval_spread(robot.pk, interval, base=base, now=robot.last_seen_at)
