"""The heartbeat interval told to robots: the site's own, longer while the web servers are
saturated.

Past its capacity a server does not slow down gracefully: heartbeats queue, robots that wait
more than 3 intervals for an answer are flipped unreachable and back, and each flip is more
work. Every answer already tells the robot when to send the next one (`heartbeat_interval`),
so the server keeps the load it is offered under its capacity by telling a longer interval,
and shortens it again when the load falls. Each robot's presence deadline follows the
interval it was told (Robot.mark_seen), so a robot that obeys is never flipped. Urgent traffic
does not wait for the interval: the push channel wakes a robot at once.

The capacity is learned, not set, from the queue of connections waiting for a web worker
(core/busy.py: read at every request's start, over windows of about 2 s):

* **A window in which the queue never emptied** (a standing queue) is a pool serving all it
  can: the processor share the pool got in it is what the machine gives it, and it is kept;
  over the processor time a request costs, it gives the requests a second the pool serves.
  Every robot then has one heartbeat waiting its turn behind the others' and sends the next
  once answered, so the fleet is as many robots as the pool serves in the time a heartbeat
  takes to be answered, about (waiting + in service) / the pool's rate (Little's law), and told
  that time over AIM the robots offer AIM of the capacity. One judgement, however far past
  capacity: a fleet starting at once against a server taking 190 a second is told 6 s in one
  step, where the controller that lengthened step by step let its queue grow for ten seconds.
  A queue that keeps each heartbeat waiting less than QUEUE_TOLERATED of the interval
  lengthens nothing (nor is it calm: the interval holds). While the robots are still hearing a
  change, the queue it answered still stands, and nothing more is asked of it; a queue that
  still stands once every robot has heard the interval lengthens it by HOLD at least.
* **Windows without a standing queue**, over a whole interval once every robot has heard it
  (then every robot has heartbeated once in them), give the rate the fleet offers at that
  interval, which is told so that it comes to AIM of the capacity learned, never under the
  site's interval. Each such judgement first raises the capacity learned by PROBE: a machine
  less loaded than when it was learned is found again, at the price of a short queue when the
  probe goes past it, which the next standing queue corrects.

Every process judges, and the one that changes the interval writes it, with the capacity it
learned, to one shared row (HeartbeatCadence), which the others read every COUNT_SECONDS and
adopt: judged by each process alone, the intervals parted (one process kept 2.5 s for a minute
while the others told 1.5 s), and the robots each process answered heartbeated at
its own. Where the queue cannot be read (no gunicorn: tests, runserver) nothing is learned.

settings.HEARTBEAT_CAPACITY stays the operator's ceiling: the robots not offline, heartbeating
at their sites' intervals, are never asked for more than 90 % of it (counted at most every
COUNT_SECONDS per process); 0 turns every lengthening off.
"""

import logging
import math
import time
from dataclasses import dataclass
from datetime import datetime, timedelta

from django.conf import settings
from django.utils import timezone

from core.busy import WINDOW_SECONDS, Window, busy
from robots.choices import Presence, RobotStatus
from robots.models import HeartbeatCadence, Robot, Site

logger = logging.getLogger(__name__)

COUNT_SECONDS = 2.0
# A backlog reported longer ago than this is over: a saturated process reports one every window.
BACKLOG_FRESH = timedelta(seconds=3 * WINDOW_SECONDS)
# The operator's ceiling tells intervals in steps of this many seconds, so robots joining or
# leaving one by one do not change every robot's interval by a few milliseconds each time.
STEP_SECONDS = 0.5
# Aim below the ceiling: robots' phases are not spread evenly.
TARGET_SHARE = 0.9
# Of the capacity learned, the share the robots are asked to offer.
AIM = 0.92
# Seconds a processor share learned with the queue standing is kept unless a larger one is.
SHARE_MEMORY = 60.0
# The processor time a request costs with the queue standing, over what the same request costs
# below saturation (contention for caches and processors): 7-8 against 5.2-6.3 ms for a plain
# heartbeat on a 2-core machine (bench/heartbeat.py --timeline). Read below
# saturation without it, the capacity came out 15-20 % too high and the interval shortened
# into a queue.
LOADED_COST = 1.1
# The capacity learned is raised by this share at a judgement at the aim, no sooner than
# PROBE_QUIET seconds after the latest standing queue; by twice as much at the next, up to
# PROBE_MAX, while no queue stands.
PROBE = 0.05
PROBE_MAX = 0.4
PROBE_QUIET = 30.0
# A queue that stood but kept a heartbeat waiting less than this share of the interval in force
# (its fewest waiting over the rate served) lengthens nothing: the pool serves all it can, and
# the wait costs the robots less than a longer interval would. Lengthened for every such queue,
# 1,000 robots held to 4.5 s by a ceiling of 250, 30-45 waiting while 210 a second were served,
# were told 5.05 s and sent 175 a second instead of 216 (bench/heartbeat.py).
QUEUE_TOLERATED = 0.25
# The learned interval is told in steps of this many seconds, and not changed by less than
# HOLD of itself (each change moves every robot's moment of the interval once).
LEARNED_STEP = 0.05
HOLD = 0.05


@dataclass
class Controller:
    """The interval the load asks for (0: none) and the capacity learned, judged from windows of
    the queue for a worker (core/busy.py)."""

    interval: float = 0.0
    # Of a processor, what this process used while the queue stood: its share of the machine
    # when the pool serves all it can (0: not learned). Over the processor time a request costs
    # now, it gives the requests a second the process would serve saturated.
    cpu_share: float = 0.0
    fleet: float = 0.0  # robots heartbeating to this pool, as last judged after they settled
    judged: Window | None = None  # the latest window judged
    judge_from: float = -math.inf  # windows starting earlier saw an interval since changed
    stood_at: float = -math.inf  # when the latest window with a standing queue ended
    share_at: float = -math.inf  # when the one cpu_share was learned from ended
    probe: float = PROBE  # the share the next probe raises the capacity learned by
    # Windows without a standing queue since judge_from, towards the next judgement.
    gathered: Window | None = None
    why: str = ""  # of the latest change

    def judge(self, window: Window, *, base: float, robots: int | None = None) -> None:
        """Lengthen or shorten the interval after `window`; `base`: the site's interval (or
        the operator's ceiling's, when longer); `robots`: how many are heartbeating to every
        web node (not offline), which the fleet estimated for this pool never exceeds."""
        if window.waiting_least is None:
            return
        if self.judged is not None and window.end <= self.judged.end:
            return
        self.judged = window
        current = max(self.interval, base)
        logger.debug(
            "heartbeat cadence window: %d-%.1f waiting, %.1f served a second, %.2f ms and %.3f "
            "of a processor a request, interval %.2f s",
            window.waiting_least,
            window.waiting,
            window.rate,
            1000 * window.cpu / max(window.served, 1),
            window.cpu / window.seconds,
            current,
        )
        settled = window.start >= self.judge_from
        if window.queue_stood:
            self._stood(window)
            if settled and window.waiting_least >= QUEUE_TOLERATED * current * window.rate:
                # Only then: judged again while the robots heard the change, every window of
                # the queue it answered lengthened it by what its own noise asked, and the
                # interval ratcheted up in steps of 0.05-0.25 s from one process to the next
                # (3.75 to 4.35 s in 10 s with 1,000 robots, bench/heartbeat.py).
                self.fleet = _fleet(window, current, robots)
                self._lengthened(window, base=base, current=current)
        elif settled:
            self.gathered = _joined(self.gathered, window)
            if self.gathered.seconds >= current:
                gathered, self.gathered = self.gathered, None
                self.fleet = _fleet(gathered, current, robots)
                self._shortened(gathered, base=base, current=current)

    def _stood(self, window: Window) -> None:
        """A window whose queue stood: the pool used all the processor it gets. The most it got
        in any such window of the last SHARE_MEMORY seconds is learned, not this window's
        alone: another process's moment (the reports' rollup every 30 s took half a processor
        for a second) left the pool 0.67 of a processor instead of 1.2, and taken as the
        machine's it lengthened the interval by 30 % (bench/heartbeat.py)."""
        share = window.cpu / window.seconds
        if share > self.cpu_share or self.share_at < window.end - SHARE_MEMORY:
            self.cpu_share, self.share_at = share, window.end
        self.stood_at, self.probe, self.gathered = window.end, PROBE, None

    def _capacity(self, window: Window) -> float:
        """Requests a second the pool would serve saturated, for requests costing what those of
        `window` did in processor time (0 before anything was learned)."""
        if window.cpu <= 0:
            return 0.0
        cost = window.cpu / window.served
        if not window.queue_stood:
            cost *= LOADED_COST
        return self.cpu_share / cost

    def _lengthened(self, window: Window, *, base: float, current: float) -> None:
        """After a window whose queue stood, once the robots heard the interval: lengthened
        to what the fleet needs, and once lengthened by HOLD at least (the queue says the
        capacity learned is too high); from the site's interval only as far as the fleet needs
        (a burst of requests makes a queue too)."""
        capacity = self._capacity(window)
        if not capacity:
            return
        wanted = self.fleet / (AIM * capacity)
        if self.interval > base:
            wanted = max(wanted, current * (1 + HOLD))
        new = min(_stepped(wanted, LEARNED_STEP), max(settings.HEARTBEAT_INTERVAL_MAX, base))
        if new > current:
            why = f"{window.waiting:.0f} waiting, {window.rate:.0f} served a second"
            queued = (window.waiting + window.pool) / window.rate
            self._change(new, at=window.end, current=current, why=why, queued=queued)

    def _shortened(self, gathered: Window, *, base: float, current: float) -> None:
        """After windows without a standing queue over one whole interval: shorten, or probe."""
        if self.interval <= base or not self._capacity(gathered):
            return
        at_aim = self.fleet / (AIM * self._capacity(gathered)) >= current * (1 - HOLD)
        if at_aim and gathered.end - self.stood_at >= PROBE_QUIET:
            # At the aim, and no queue stood for a while: look for more, in case the capacity
            # learned was the machine's at a worse moment; twice as much each time no queue
            # came of it, back to PROBE when one does.
            self.cpu_share = max(self.cpu_share, gathered.cpu / gathered.seconds) * (1 + self.probe)
            self.probe = min(2 * self.probe, PROBE_MAX)
        wanted = self.fleet / (AIM * self._capacity(gathered))
        new = max(_stepped(wanted, LEARNED_STEP), base)
        if new < current:
            why = f"no queue, {gathered.rate:.0f} served a second"
            self._change(new, at=gathered.end, current=current, why=why)

    def _change(self, new: float, *, at: float, current: float, why: str, queued: float = 0.0):
        self.why = f"{why}: interval {current:.2f} -> {new:.2f} s"
        self.interval = new
        self.judge_from = at + _settling(current, queued)
        self.gathered = None

    def adopt(
        self, interval: float, cpu_share: float, *, at: float, base: float, queued: float = 0.0
    ) -> None:
        """Another process's decision, heard at clock time `at`, made with heartbeats waiting
        `queued` seconds for a worker: this one tells it from now on and judges as if it had
        made it."""
        current = max(self.interval, base)
        self.interval, self.cpu_share = interval, cpu_share
        self.judge_from = at + _settling(current, queued)
        self.gathered = None


def _fleet(window: Window, interval: float, robots: int | None) -> float:
    """Robots heartbeating to this process's pool, by Little's law: those whose heartbeat waits
    for a worker, those being served, and those waiting `interval` after their answer (the
    pool's rate x `interval`); never more than `robots`, all there are."""
    fleet = window.waiting + window.pool + window.rate * interval
    return min(fleet, robots or math.inf)


def _joined(gathered: Window | None, window: Window) -> Window:
    """`window` added to the windows gathered before it (their queue means weighted by time)."""
    if gathered is None:
        return window
    seconds = gathered.seconds + window.seconds
    waiting = (gathered.waiting * gathered.seconds + window.waiting * window.seconds) / seconds
    return Window(
        gathered.start,
        window.end,
        gathered.served + window.served,
        gathered.cpu + window.cpu,
        waiting=waiting,
        waiting_least=min(gathered.waiting_least, window.waiting_least),
        pool=window.pool,
    )


def _settling(before: float, queued: float) -> float:
    """Seconds until every robot has heard an interval that replaced `before`, with heartbeats
    waiting `queued` seconds for a worker: each hears it with the answer to its next heartbeat,
    sent within `before` (1.5 times it while it moves to its moment of a longer interval,
    heartbeat_interval_spread) and answered once the queue reaches it. Judged earlier, a queue
    left by the interval before, draining after a fleet's start, lengthened it three times
    over what it needed (in a simulation)."""
    return queued + 1.5 * before


_controller = Controller()


@dataclass
class _Count:
    robots: int = 0
    read_at: float = -math.inf


_count = _Count()


@dataclass
class _Shared:
    """The row of the interval shared by every web process (HeartbeatCadence), as last heard."""

    changed_at: datetime | None = None  # of the decision this process last heard or made
    read_at: float = -math.inf


_shared = _Shared()


def heartbeat_interval_told(site: Site) -> float:
    """Seconds the robot should wait before its next heartbeat: the site's interval, or longer
    while the web servers are saturated or the fleet would exceed the operator's ceiling."""
    if not settings.HEARTBEAT_CAPACITY:
        return site.heartbeat_interval
    ceiling = _ceiling_interval(site)
    if time.monotonic() - _shared.read_at >= COUNT_SECONDS:
        _shared_heard(base=ceiling)
    if busy.last is not None:
        before, judged = (_controller.interval, _controller.cpu_share), _controller.judged
        _controller.judge(busy.last, base=ceiling, robots=_robots_heartbeating())
        if _controller.judged is not judged and busy.last.queue_stood:
            _backlog_tell(busy.last)
        if _controller.interval != before[0]:
            if _shared_tell(_controller.interval, _controller.cpu_share):
                logger.info("heartbeat cadence: %s", _controller.why)
            else:  # another process decided first, judging the same load: its decision stands
                _controller.interval, _controller.cpu_share = before
                _shared_heard(base=ceiling)
    return max(_controller.interval, ceiling)


def _shared_heard(*, base: float) -> None:
    """Adopt the shared interval if another process changed it since this one last heard or
    changed it."""
    _shared.read_at = time.monotonic()
    row = (
        HeartbeatCadence.objects.filter(pk=1)
        .values_list("interval", "cpu_share", "changed_at", "backlog_seconds", "backlog_at")
        .first()
    )
    if row is None or row[2] is None or row[2] == _shared.changed_at:
        return
    interval, cpu_share, _shared.changed_at, backlog, backlog_at = row
    if interval == _controller.interval:
        return
    # The queue the decision answered: until it has drained the robots have not all heard it.
    # Adopted as if none stood, another process judged its windows 1.5 s later and lengthened
    # the interval again, 3.10 to 3.70 s in 4 s (bench/heartbeat.py).
    fresh = backlog_at is not None and backlog_at >= _shared.changed_at - BACKLOG_FRESH
    queued = backlog if fresh else 0.0
    _controller.adopt(interval, cpu_share, at=time.monotonic(), base=base, queued=queued)


def _shared_tell(interval: float, cpu_share: float) -> bool:
    """This process's decision, for the others to adopt (they read it every COUNT_SECONDS):
    written only if no other process wrote one since this one last heard the row (a conditional
    UPDATE); whether it stands."""
    now = timezone.now()
    values = {"interval": interval, "cpu_share": cpu_share, "changed_at": now}
    rows = HeartbeatCadence.objects.filter(pk=1)
    written = rows.filter(changed_at=_shared.changed_at).update(**values) or _row_made(values)
    if written:
        _shared.changed_at = now
    return bool(written)


def _row_made(values: dict) -> bool:
    """The shared row made with `values` if there was none (the migration makes it; a flushed
    database loses it): INSERT ... ON CONFLICT DO NOTHING, so another process making it at the
    same moment is no error. Whether these values are in it."""
    if HeartbeatCadence.objects.filter(pk=1).exists():
        return False
    HeartbeatCadence.objects.bulk_create([HeartbeatCadence(pk=1, **values)], ignore_conflicts=True)
    return HeartbeatCadence.objects.filter(pk=1, **values).exists()


def _backlog_tell(window: Window) -> None:
    """The wait for a worker a window whose queue stood saw, for the presence sweep."""
    values = {"backlog_seconds": window.waiting / window.rate, "backlog_at": timezone.now()}
    if not HeartbeatCadence.objects.filter(pk=1).update(**values):
        _row_made(values)


def heartbeat_backlog(now: datetime) -> float:
    """Seconds a heartbeat arriving at `now` waits for a web worker, as a web process whose
    queue stood last reported it (within BACKLOG_FRESH; 0 otherwise): its robot is not late
    for those seconds (robots.services.presence_sweep)."""
    backlog = (
        HeartbeatCadence.objects.filter(pk=1, backlog_at__gt=now - BACKLOG_FRESH)
        .values_list("backlog_seconds", flat=True)
        .first()
    )
    return backlog or 0.0


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


def heartbeat_interval_spread(
    robot_id: int, interval: float, *, base: float, now: datetime
) -> float:
    """`interval` as told at `now` to the robot `robot_id`: one longer than the site's `base`
    ends at the robot's own moment of the interval (its slot), so robots heartbeat spread
    over it.

    A robot keeps its phase: it heartbeats the told interval after its last one. Every robot
    hears a longer interval within one of the site's (all of them within a second at 1 s), so
    told 4.5 s a fleet spread over one second went on heartbeating together in one second of
    every 4.5, as many a second as before it was slowed (bench/heartbeat.py, 1,000 robots under
    a ceiling of 250: p99 298 ms at 228 heartbeats a second).
    Each robot's slot is a fixed share of the interval, on the wall clock (the same on
    every node): the fractional part of its id times the golden ratio's inverse (the same in
    every process), so robots with ids in a row take slots as evenly apart as they can be,
    whatever their number (Weyl's sequence). Taken from a crc32 of their codes, the slots of
    1,000 robots coded H0001 to H1000 came 31 to 69 to a twentieth of the interval where 50 were
    due, and the densest twentieths queued at 89 % of what the server takes.
    The robot is told to come at its first slot at least half the interval, and the site's,
    from now. So it is told between that and one interval more, once, and the interval itself
    (less the time its heartbeat took to arrive) while it keeps to its slot."""
    if interval <= base:
        return interval
    slot = math.modf(robot_id * _GOLDEN)[0] * interval
    earliest = now.timestamp() + max(base, interval / 2)
    at = slot + math.ceil((earliest - slot) / interval) * interval
    return round(at - now.timestamp(), 3)


_GOLDEN = (math.sqrt(5) - 1) / 2


def _ceiling_interval(site: Site) -> float:
    """The site's interval, or the longer one that keeps the robots heartbeating under 90 % of
    the operator's ceiling (at most HEARTBEAT_INTERVAL_MAX, unless the site's own is longer)."""
    needed = _robots_heartbeating() / (settings.HEARTBEAT_CAPACITY * TARGET_SHARE)
    if needed <= site.heartbeat_interval:
        return site.heartbeat_interval
    # The cap bounds how much the load lengthens it, never shortens a site's own interval.
    return max(min(_stepped(needed), settings.HEARTBEAT_INTERVAL_MAX), site.heartbeat_interval)


def _stepped(seconds: float, step: float = STEP_SECONDS) -> float:
    """`seconds` rounded up to a whole number of `step`s."""
    return round(math.ceil(round(seconds / step, 9)) * step, 3)


def _robots_heartbeating() -> int:
    now = time.monotonic()
    if now - _count.read_at >= COUNT_SECONDS:
        _count.robots = Robot.objects.exclude(presence=Presence.OFFLINE).count()
        _count.read_at = now
    return _count.robots


def cadence_forget() -> None:
    """Count again on the next heartbeat, and forget the windows, the shared row as heard and what
    they asked (tests)."""
    _count.read_at = -math.inf
    vars(_shared).update(vars(_Shared()))
    vars(_controller).update(vars(Controller()))
    busy.forget()
