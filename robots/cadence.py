"""The heartbeat interval told to robots: the site's own, longer while the web servers are
saturated.

Past its capacity a server does not slow down gracefully: heartbeats queue, robots that wait
more than 3 intervals for an answer are flipped unreachable and back, and each flip is more
work. Every answer already tells the robot when to send the next one (`heartbeat_interval`),
so the server keeps the load it is offered under its capacity by telling a longer interval,
and shortens it again when the load falls. Each robot's presence deadline follows the
interval it was told (Robot.mark_seen), so a robot that obeys is never flipped. Urgent traffic
does not wait for the interval: the push channel wakes a robot at once.

The capacity is learned, not set: each web process measures the share of wall time it spends
serving requests (core/busy.py, every request, over windows of about 2 s), a sample of the
whole pool's since sync workers share one socket; the controller judges the share over
consecutive windows covering at least the interval in force, in which every robot heartbeats
once (robots answered at the workers' pace after a backlog come back bunched: a single 2 s
window would see the bunch or the gap after it). After a judgement busier than HIGH_SHARE in
which requests waited for a worker (where gunicorn hands its listening sockets over, more than
WAITING_HIGH connections waiting on them on average) the interval is lengthened towards the
one that would bring the share down to AIM_SHARE, at least one step; after one so idle that
one step shorter would still leave it under LOW_SHARE (estimated as if the share were
proportional to the rate), it is shortened by one step, never below the site's own interval.
Between the two it holds, so a steady load settles on one interval instead of swinging between
two; and after a change it judges no window until every robot has heard the new interval (the
interval before the change), so it does not answer one overload twice. No shared state, no
query.

settings.HEARTBEAT_CAPACITY stays the operator's ceiling: the robots not offline, heartbeating
at their sites' intervals, are never asked for more than 90 % of it (counted at most every
COUNT_SECONDS per process); 0 turns every lengthening off.
"""

import logging
import math
import time
import zlib
from dataclasses import dataclass
from datetime import datetime

from django.conf import settings

from core.busy import Window, busy
from robots.choices import Presence, RobotStatus
from robots.models import Robot, Site

logger = logging.getLogger(__name__)

COUNT_SECONDS = 2.0
# Intervals are told in steps of this many seconds, so robots joining or leaving one by one do
# not change every robot's interval by a few milliseconds each time.
STEP_SECONDS = 0.5
# Aim below the ceiling: robots' phases are not spread evenly.
TARGET_SHARE = 0.9
# Of a web process's wall time spent serving (core/busy.py).
HIGH_SHARE = 0.8  # busier: requests queue for a worker, lengthen
AIM_SHARE = 0.6  # what lengthening aims at
LOW_SHARE = 0.4  # shorten only while one step shorter would stay under this
# Connections waiting for a worker, on average at requests' starts (core/busy.py): under this,
# a busy share over HIGH_SHARE is a pool near what it takes, not past it. The share reads about
# 83 % at most, near it as past it; 1,000 robots (bench/heartbeat.py, 2026-11-25) had 1-10
# connections waiting while served at 1.5 s, 190-800 whenever the interval was lengthened.
WAITING_HIGH = 20


@dataclass
class Controller:
    """The interval the load asks for (0: none), judged from windows of the busy share."""

    interval: float = 0.0
    judged_until: float = -math.inf  # windows ending earlier were judged
    judge_from: float = -math.inf  # windows starting earlier saw an interval since changed
    gathered: float = 0.0  # seconds of windows gathered towards the next judgement
    gathered_busy: float = 0.0  # of which spent serving
    gathered_waiting: float | None = 0.0  # connections waiting x seconds; None: not known

    def judge(self, window: Window, *, base: float) -> None:
        """Lengthen or shorten the interval after windows covering one interval; `base`: the
        site's interval."""
        if window.end <= self.judged_until or window.start < self.judge_from:
            return
        self.judged_until = window.end
        current = max(self.interval, base)
        # The share over at least one whole interval, in which every robot heartbeats once: a
        # shorter window over robots whose phases bunched (a backlog drained at the workers'
        # pace sends them back together) sees either the bunch or the gap after it.
        seconds = window.end - window.start
        self.gathered += seconds
        self.gathered_busy += window.share * seconds
        if window.waiting is None or self.gathered_waiting is None:
            self.gathered_waiting = None
        else:
            self.gathered_waiting += window.waiting * seconds
        if self.gathered < current:
            return
        share = self.gathered_busy / self.gathered
        waiting = None if self.gathered_waiting is None else self.gathered_waiting / self.gathered
        self.gathered = self.gathered_busy = self.gathered_waiting = 0.0
        shorter = max(current - STEP_SECONDS, base)
        logger.debug("heartbeat cadence: busy %.0f%%, waiting %s", 100 * share, waiting)
        saturated = share > HIGH_SHARE and (waiting is None or waiting > WAITING_HIGH)
        if saturated:
            wanted = max(current * share / AIM_SHARE, current + STEP_SECONDS)
            new = min(_stepped(wanted), max(settings.HEARTBEAT_INTERVAL_MAX, base))
        elif self.interval > base and share * current / shorter < LOW_SHARE:
            # Towards the interval that would bring the share to AIM_SHARE, as lengthening
            # does, not one step per judgement: a burst of requests saturates the workers for
            # a moment, and robots without the push channel would otherwise wait minutes of
            # long intervals for their plans once it is over.
            new = min(max(_stepped(current * share / AIM_SHARE), base), shorter)
        else:
            return
        if max(new, base) != current:
            logger.info(
                "heartbeat cadence: busy %.0f%%, waiting %s, interval %.1f -> %.1f s",
                100 * share,
                "-" if waiting is None else f"{waiting:.1f}",
                current,
                max(new, base),
            )
            self.interval = new
            # Robots hear of it at their next heartbeat, at most `current` seconds from now.
            self.judge_from = window.end + current


_controller = Controller()


@dataclass
class _Count:
    robots: int = 0
    read_at: float = -math.inf


_count = _Count()


def heartbeat_interval_told(site: Site) -> float:
    """Seconds the robot should wait before its next heartbeat: the site's interval, or longer
    while the web servers are saturated or the fleet would exceed the operator's ceiling."""
    if not settings.HEARTBEAT_CAPACITY:
        return site.heartbeat_interval
    ceiling = _ceiling_interval(site)
    if busy.last is not None:
        # Judged from the interval robots are told, the ceiling's when that is longer: the
        # share is what robots at that interval cause, and it is over that interval that every
        # robot heartbeats once (judged from its own shorter one, the controller swung between
        # 1 and 2.5 s under a ceiling's 4.5 s while heartbeats queued, 2026-11-24).
        _controller.judge(busy.last, base=ceiling)
    return max(_controller.interval, ceiling)


def heartbeat_interval_idle(told: float, heartbeat: dict) -> float:
    """The interval for a robot idle with its push channel open: HEARTBEAT_IDLE_INTERVAL if
    longer than `told` (heartbeat_interval_told), else `told`.

    Idle: the validated `heartbeat` says `push` (the robot holds the push channel), status
    idle, nothing on board, and carries no events or requests. Such a robot has nothing to
    report until the server posts it something, and the push channel wakes it at once when it
    does, so its heartbeats only say it is still there: at the defaults, a fleet waiting at its
    docks sends a fifth of the heartbeats. boards.services.heartbeat_apply tells `told` instead
    when its answer carries messages: the robot has work coming."""
    if not settings.HEARTBEAT_IDLE_INTERVAL or not heartbeat.get("push"):
        return told
    state = heartbeat["state"]
    if state["status"] != RobotStatus.IDLE or state["load"]:
        return told
    if heartbeat["events"] or heartbeat["requests"]:
        return told
    return max(told, float(settings.HEARTBEAT_IDLE_INTERVAL))


def heartbeat_interval_spread(code: str, interval: float, *, base: float, now: datetime) -> float:
    """`interval` as told at `now` to robot `code`: one longer than the site's `base` ends at the
    robot's own moment of the interval (its slot), so robots heartbeat spread over it.

    A robot keeps its phase: it heartbeats the told interval after its last one. Every robot
    hears a longer interval within one of the site's (all of them within a second at 1 s),
    so told 4.5 s a fleet spread over one second went on heartbeating together in one second
    of every 4.5, as many a second as before it was slowed (bench/heartbeat.py, 1,000
    robots under the default ceiling, 2026-11-25: p99 298 ms at 228 heartbeats a second;
    README). Each robot's slot is a fixed share of the interval, from its code (crc32: the
    same in every process), on the wall clock (the same on every node); the robot is told
    to come at its first slot at least half the interval, and the site's, from now. So it
    is told between that and one interval more, once, and the interval itself (less the
    time its heartbeat took to arrive) while it keeps to its slot."""
    if interval <= base:
        return interval
    slot = zlib.crc32(code.encode()) / 2**32 * interval
    earliest = now.timestamp() + max(base, interval / 2)
    at = slot + math.ceil((earliest - slot) / interval) * interval
    return round(at - now.timestamp(), 3)


def _ceiling_interval(site: Site) -> float:
    """The site's interval, or the longer one that keeps the robots heartbeating under 90 % of
    the operator's ceiling (at most HEARTBEAT_INTERVAL_MAX, unless the site's own is longer)."""
    needed = _robots_heartbeating() / (settings.HEARTBEAT_CAPACITY * TARGET_SHARE)
    if needed <= site.heartbeat_interval:
        return site.heartbeat_interval
    # The cap bounds how much the load lengthens it, never shortens a site's own interval.
    return max(min(_stepped(needed), settings.HEARTBEAT_INTERVAL_MAX), site.heartbeat_interval)


def _stepped(seconds: float) -> float:
    return math.ceil(round(seconds / STEP_SECONDS, 9)) * STEP_SECONDS


def _robots_heartbeating() -> int:
    now = time.monotonic()
    if now - _count.read_at >= COUNT_SECONDS:
        _count.robots = Robot.objects.exclude(presence=Presence.OFFLINE).count()
        _count.read_at = now
    return _count.robots


def cadence_forget() -> None:
    """Count again on the next heartbeat, and forget the busy share and what it asked (tests)."""
    _count.read_at = -math.inf
    vars(_controller).update(vars(Controller()))
    busy.forget()
