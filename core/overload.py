"""The heartbeat interval told to robots under load: one rule, from two signals.

Every answer tells the robot when to send its next heartbeat (`heartbeat_interval`), so a
server offered more heartbeats than it can take answers with a longer interval instead of
letting them queue. Two signals say when:

* **The operator's ceiling** (settings.HEARTBEAT_CAPACITY, heartbeats a second the web nodes
  are asked for together): the robots not offline, at their sites' interval, are never asked
  for more than CAPACITY_SHARE of it.
* **The wait for a worker**: nginx stamps each request with the time it passed it on
  (`X-Request-Start: t=<seconds>`, the header application-performance tools read), so the
  view knows how long the heartbeat waited before a worker took it. A robot whose heartbeat
  waited more than WAIT_SHARE of the interval it was told is told that interval plus the
  wait; one that waited less is told STEP_SECONDS less, down to the site's. Across the fleet
  the intervals settle where the server is just saturated and the wait stays a small part
  of each robot's cycle, whatever the machine.

Nothing here reads the server software, the kernel or a shared counter: the wait comes with
the request and the interval a robot was told last is stored on its row. The presence
deadlines follow the interval told (Robot.mark_seen), so a robot that obeys is never flipped,
and heartbeat_interval_spread spreads the robots told a longer interval over it. Urgent
traffic does not wait for the interval: the push channel wakes a robot at once.
"""

import math
from datetime import datetime

# Of the operator's ceiling, the share the robots are asked for: their phases are not even.
CAPACITY_SHARE = 0.9
# A heartbeat may wait this share of its interval for a worker before the interval grows.
WAIT_SHARE = 0.25
# Intervals are told in steps of this many seconds, and shortened by one step at a time.
STEP_SECONDS = 0.5
# Seconds a process keeps its count of the robots heartbeating (robots.selectors).
COUNT_SECONDS = 2.0


def heartbeat_interval(
    *, base: float, previous: float, waited: float, robots: int, capacity: int, longest: float
) -> float:
    """Seconds until the robot's next heartbeat: the site's `base`, or longer while the fleet
    (`robots` not offline) would pass the operator's `capacity` (0: never longer) or while
    this heartbeat `waited` for a worker a large share of the `previous` interval told to
    the robot. Never over `longest`, unless the site's own is."""
    if not capacity:
        return base
    previous = max(previous, base)
    waited_long = waited > WAIT_SHARE * previous
    measured = previous + waited if waited_long else previous - STEP_SECONDS
    wanted = max(base, robots / (capacity * CAPACITY_SHARE), measured)
    return max(min(_stepped(wanted), longest), base)


def request_waited(stamp: str | None, *, now: float) -> float:
    """Seconds a request waited between the proxy and the worker, from the proxy's
    `X-Request-Start` header (`t=<seconds since the epoch>`, nginx's $msec) read at clock time
    `now`; 0 without the header, for a malformed one or clocks that disagree."""
    if not stamp:
        return 0.0
    try:
        started = float(stamp.removeprefix("t="))
    except ValueError:
        return 0.0
    waited = now - started
    # nginx gives up on an upstream after 60 s (proxy_read_timeout): a longer wait is clocks
    # that disagree, or a stamp the client wrote itself where no proxy replaced it.
    return waited if 0.0 < waited < 60.0 else 0.0


def heartbeat_interval_spread(
    robot_id: int, interval: float, *, base: float, now: datetime
) -> float:
    """`interval` as told at `now` to the robot `robot_id`: one longer than the site's `base`
    ends at the robot's own moment of the interval (its slot), so robots heartbeat spread
    over it instead of all in the same second of every interval, as they would if each kept
    its phase.

    Each robot's slot is a fixed share of the interval on the wall clock (the same on every
    node): the fractional part of its id times the golden ratio's inverse, so robots with ids
    in a row take slots as evenly apart as they can be, whatever their number (Weyl's
    sequence). The robot is told to come at its first slot at least half the interval, and
    the site's, from now."""
    if interval <= base:
        return interval
    slot = math.modf(robot_id * _GOLDEN)[0] * interval
    earliest = now.timestamp() + max(base, interval / 2)
    at = slot + math.ceil((earliest - slot) / interval) * interval
    return round(at - now.timestamp(), 3)


_GOLDEN = (math.sqrt(5) - 1) / 2


def _stepped(seconds: float) -> float:
    """`seconds` rounded up to a whole number of STEP_SECONDS."""
    return round(math.ceil(round(seconds / STEP_SECONDS, 9)) * STEP_SECONDS, 3)
