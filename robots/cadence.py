"""The heartbeat interval told to robots: the site's own, longer when the fleet would send more
heartbeats than the servers take (settings.HEARTBEAT_CAPACITY).

Past its capacity a server does not slow down gracefully: heartbeats queue, robots that wait
more than 3 intervals for an answer are flipped unreachable and back, and each flip is more
work. Every answer already tells the robot when to send the next one (`heartbeat_interval`),
so the server keeps the load it is offered under its capacity by telling a longer interval,
and shortens it again when robots go offline. Each robot's presence deadline follows the
interval it was told (Robot.mark_seen), so a robot that obeys is never flipped. Urgent traffic
does not wait for the interval: the push channel wakes a robot at once.

The load is estimated from the robots that may be heartbeating (not offline), counted at most
every COUNT_SECONDS per process: no shared state, and no query on nearly every heartbeat.
"""

import math
import time
from dataclasses import dataclass

from django.conf import settings

from robots.choices import Presence
from robots.models import Robot, Site

COUNT_SECONDS = 2.0
# Intervals are told in steps of this many seconds, so robots joining or leaving one by one do
# not change every robot's interval by a few milliseconds each time.
STEP_SECONDS = 0.5
# Aim below the capacity: robots' phases are not spread evenly, and pages, API and sweeps
# share the servers.
TARGET_SHARE = 0.9


@dataclass
class _Count:
    robots: int = 0
    read_at: float = -math.inf


_count = _Count()


def heartbeat_interval_told(site: Site) -> float:
    """Seconds the robot should wait before its next heartbeat: the site's interval, or longer
    when all robots heartbeating at their sites' intervals would exceed the capacity."""
    capacity = settings.HEARTBEAT_CAPACITY * TARGET_SHARE
    if not capacity:
        return site.heartbeat_interval
    needed = _robots_heartbeating() / capacity  # seconds between one robot's heartbeats
    if needed <= site.heartbeat_interval:
        return site.heartbeat_interval
    stepped = math.ceil(needed / STEP_SECONDS) * STEP_SECONDS
    # The cap bounds how much the load lengthens it, never shortens a site's own interval.
    return max(min(stepped, settings.HEARTBEAT_INTERVAL_MAX), site.heartbeat_interval)


def _robots_heartbeating() -> int:
    now = time.monotonic()
    if now - _count.read_at >= COUNT_SECONDS:
        _count.robots = Robot.objects.exclude(presence=Presence.OFFLINE).count()
        _count.read_at = now
    return _count.robots


def cadence_forget() -> None:
    """Count again on the next heartbeat (tests)."""
    _count.read_at = -math.inf
