"""One simulated delivery robot: it follows its plan on its own map and talks only protocol v1.

What the robot knows: its map (the site file, as robots.router.SiteMap), its dock, and what its
RobotClient receives. It never reads the server's database.

Its behaviour, as in the source paper (sections 2.2, 3.2 and 4.3):

* it drives the current plan's stops in order, hop by hop along the shortest path of its own
  router at the site's speed; a newer plan takes effect at the next waypoint (never inside a
  door, corridor or elevator);
* before a guarded edge (an automatic door, a narrow corridor) it stops at the waiting
  waypoint, sends `acquire` and waits, queued, until its grant comes; then it reports
  `resource_entered`, passes, and reports `resource_released` on the far side;
* for an elevator it asks at the boarding lobby with `to_floor`; on the grant it reports
  `resource_entered` and waits until that report has reached the server (the cabin has no
  network), rides (overhead + floors × seconds per floor) offline, and reports
  `resource_released` from the lobby of the target floor;
* at a stop it reports `arrived`, waits for the staff to press the button (a random delay),
  reports `loaded`/`unloaded`, and `task_completed` after the last stop of a task;
* a secure delivery (its plan task has `secure`) is locked in a free lockable compartment; at
  the drop-off the simulated recipient types the PIN (`pins`: what the requester was told,
  if the recipient knows it), sometimes wrongly; the robot checks it offline
  (robotsim.client.pin_check) and after `max_attempts` wrong ones keeps it locked and reports
  `compartment_locked`;
* the battery drains while it moves and charges while it stands at its dock with nothing to do;
* `action` messages: `pause` (stops at the next waypoint), `resume`, `return_to_dock`;
* `elevator_exit` (a fire alarm): it gets out of the car at the lobby the message names (or
  the car's next floor) and carries on from there, waiting for what the server says next. It
  hears it in the cabin only if the cabins have network (`Behaviour.cabin_network`), else
  before the doors close or never (then it rides on, as a v1 robot would).

Time: everything here runs on a simulated clock (`clock.now()`, seconds); a RobotLoop sends
heartbeats on the real one. The robot's behaviour is a generator ("program") that yields
what it waits for, a duration (`Sleep`) or a condition (`Until`); `advance()` resumes it
whenever that is over, so a coarse driver step loses no precision.
"""

from __future__ import annotations

import logging
import math
import random
import time
from collections.abc import Callable, Generator
from dataclasses import dataclass, field
from datetime import UTC, datetime

from robots.router import Router, SiteMap, edge_index
from robotsim.client import RefusedError, RobotClient, badge_check, pin_check

logger = logging.getLogger("robotsim")

PICKUP, DROPOFF, DOCK = "pickup", "dropoff", "dock"


# --- Clocks ------------------------------------------------------------------------------------


class RealClock:
    """Simulated seconds that run `speedup` times faster than real (monotonic) time."""

    def __init__(self, speedup: float = 1.0):
        if speedup <= 0:
            raise ValueError("speedup must be positive")
        self.speedup = speedup
        self._started = time.monotonic()

    def now(self) -> float:
        return (time.monotonic() - self._started) * self.speedup


class ManualClock:
    """A clock that moves only when told (deterministic runs, tests)."""

    speedup = 1.0

    def __init__(self, start: float = 0.0):
        self._now = start

    def now(self) -> float:
        return self._now

    def set(self, now: float) -> None:
        if now < self._now:
            raise ValueError("time does not go backwards")
        self._now = now


# --- What the program waits for ----------------------------------------------------------------


@dataclass(frozen=True)
class Sleep:
    seconds: float


@dataclass(frozen=True)
class Until:
    condition: Callable[[], bool]


Program = Generator[Sleep | Until, None, None]


# --- Settings and bookkeeping ------------------------------------------------------------------


@dataclass(frozen=True)
class Behaviour:
    """How the robot and the people around it behave; simulated seconds."""

    staff_delay: tuple[float, float] = (15.0, 60.0)  # arrival to button press, uniform
    battery: float = 1.0  # at start
    drain_moving: float = 1 / (8 * 3600)  # per second moving: 8 h on a full battery
    drain_idle: float = 1 / (48 * 3600)
    charge_rate: float = 1 / (2 * 3600)  # per second at the dock: full in 2 h
    wrong_pin: float = 0.2  # a recipient who knows the PIN mistypes it (once) this often
    pin_seconds: float = 8.0  # to type a PIN
    badge_share: float = 0.5  # where a user of the unit has a badge, it opens this often
    # As the site file says (battery_per_metre, battery_per_ride), when given: then driving
    # drains per metre instead of per second, and each elevator ride drains too.
    drain_per_metre: float | None = None
    drain_per_ride: float = 0.0
    # The lift cabins have network (a repeater in the shaft): the robot hears its board while
    # riding, so an `elevator_exit` reaches it there. Without, it is silent from the doors
    # closing to its destination, as in the source paper's trial.
    cabin_network: bool = False

    @classmethod
    def for_site(cls, site: dict, **options) -> Behaviour:
        """Draining as the site file says the server expects (its defaults when it says not)."""
        return cls(
            drain_per_metre=float(site.get("battery_per_metre", 0.00004)),
            drain_per_ride=float(site.get("battery_per_ride", 0.001)),
            **options,
        )


@dataclass
class RobotStats:
    distance: float = 0.0  # metres driven
    moving: float = 0.0  # seconds driving
    riding: float = 0.0  # seconds in elevator cabins
    rides: int = 0
    loaded: int = 0
    unloaded: int = 0
    completed: int = 0

    @property
    def travel(self) -> float:
        """Seconds on the way: driving and riding."""
        return self.moving + self.riding


@dataclass(frozen=True)
class _Motion:
    source: str
    target: str
    started: float
    ends: float


@dataclass
class _Hop:
    """The next step towards a target: an edge, a guarded passage or an elevator ride."""

    kind: str  # "edge", "guarded" or "ride"
    target: str  # the next waypoint (for "guarded": the far end of the passage)
    resource: str | None = None
    path: list[str] = field(default_factory=list)  # "guarded": every waypoint passed
    to_floor: str | None = None


# --- The robot ---------------------------------------------------------------------------------


class SimRobot:
    """A simulated robot. Drive it with advance() (motion) and report() (state for the next
    heartbeat); the messages its client receives reach it through the client's handlers."""

    def __init__(
        self,
        *,
        client: RobotClient,
        site_map: SiteMap,
        dock: str,
        clock,
        rng: random.Random,
        behaviour: Behaviour | None = None,
        router: Router | None = None,
        dead_zones: frozenset[str] = frozenset(),
        compartments: list[dict] = (),
        pins: Callable[[str], str | None] = lambda task: None,
        badges: Callable[[str], str | None] = lambda station: None,
        maps: Callable[[int], tuple[SiteMap, Router] | None] | None = None,
    ):
        self.client = client
        # A new map version announced in a heartbeat answer (map_version) is taken from `maps`
        # (however the robot fetches its site file) at the next waypoint both maps have.
        self.maps = maps
        self.map_version: int | None = None  # of the map it drives on; None: the one given
        self._map_wanted: int | None = None
        self.lockable = [c["code"] for c in compartments if c.get("lockable")]
        self.locked: dict[str, str] = {}  # task -> the compartment its items are locked in
        self.pins = pins
        self.badges = badges  # station -> the badge id of a user of its unit, if any
        self.code = client.robot
        self.map = site_map
        self.router = router or Router(site_map)
        self.clock = clock
        self.rng = rng
        self.behaviour = behaviour or Behaviour()
        self.dock = dock
        self.dead_zones = dead_zones
        self.waypoint = dock
        self.status = "charging"
        self.battery = self.behaviour.battery
        self.lowest_battery = self.battery  # for the benchmarks
        self.paused = False
        self.riding = False
        self.stops: list[dict] = []  # the current plan's stops still to do, in order
        self.tasks: dict[str, dict] = {}  # what plans said about each task
        self.done: set[tuple[str, int]] = set()  # (task, stop) loaded or unloaded here
        self.completed: set[str] = set()
        self.on_board: dict[str, int] = {}  # items per task
        self.log: list[dict] = []  # every event and request, as sent
        self.stats = RobotStats()
        self.urgent = False  # something new to tell: heartbeat soon
        self._edges = edge_index(site_map)
        self._grants: dict[str, dict] = {}  # resource -> newest grant received
        self._inside: str | None = None  # the elevator it rides
        self._exit: dict | None = None  # an elevator_exit for that elevator
        self._changes = 0  # plans and actions received: waits re-check their reason
        self._motion: _Motion | None = None
        self._mode = "charging"  # battery accounting: moving, riding, idle or charging
        self._accounted = clock.now()
        self._time = clock.now()  # the program's time: when what it waited for was over
        self._waiting: Sleep | Until | None = None
        self._wake_at: float | None = None
        self._program = self._run()
        client.on_map_version(self._on_map_version)
        client.on("plan", self._on_plan)
        client.on("resource_grant", self._on_grant)
        client.on("action", self._on_action)
        client.on("elevator_exit", self._on_exit)

    # --- Driving the program ---------------------------------------------------------------

    def advance(self) -> None:
        """Run the program up to the clock's now."""
        now = self.clock.now()
        while True:
            waiting = self._waiting
            if isinstance(waiting, Sleep):
                if self._wake_at > now:
                    break
                self._time = self._wake_at
            elif isinstance(waiting, Until):
                if not waiting.condition():
                    break
                self._time = max(self._time, now)
            self._account(self._time)
            waiting = next(self._program)
            self._waiting = waiting
            self._wake_at = self._time + waiting.seconds if isinstance(waiting, Sleep) else None
        self._account(now)

    def next_timer(self) -> float | None:
        """Simulated seconds until the program's current Sleep ends; None if it waits for a
        condition (a message, a delivered event)."""
        if self._wake_at is None:
            return None
        return max(self._wake_at - self.clock.now(), 0.0)

    def connected(self) -> bool:
        """The network is there: not in an elevator cabin, not in a dead zone (from a dead-zone
        waypoint until the next waypoint: an access-point handover)."""
        in_cabin = self.riding and not self.behaviour.cabin_network
        return not in_cabin and self.waypoint not in self.dead_zones

    def report(self) -> None:
        """Put the robot's current state into its client, for the next heartbeat."""
        now = self.clock.now()
        self._account(now)
        x, y, heading = self._position(now)
        waypoint = self.map.waypoints[self.waypoint]
        self.client.update_state(
            status=self.status,
            floor=waypoint.floor,
            waypoint=self.waypoint,
            x=round(x, 2),
            y=round(y, 2),
            heading=round(heading, 3),
            battery=round(min(max(self.battery, 0.0), 1.0), 4),
            load=sum(self.on_board.values()),
        )

    @property
    def idle_at_dock(self) -> bool:
        return not self.stops and self.waypoint == self.dock and self._motion is None

    # --- Messages (called by the client, inside a heartbeat) ------------------------------

    def _on_plan(self, plan: dict) -> None:
        self.tasks.update(plan.get("tasks", {}))
        self.stops = [stop for stop in plan["stops"] if _key(stop) not in self.done]
        self._changes += 1
        logger.info("%s: plan %s: %s", self.code, plan["plan_version"], _describe(self.stops))

    def _on_grant(self, grant: dict) -> None:
        self._grants[grant["resource"]] = grant

    def _on_exit(self, message: dict) -> None:
        """Get out of the car at its next stop (a fire alarm); nothing if already out."""
        if message.get("resource") == self._inside:
            self._exit = message
            logger.info("%s: told to get out of %s", self.code, self._inside)

    def _on_action(self, message: dict) -> None:
        action = message["action"]
        if action == "pause":
            self.paused = True
        elif action == "resume":
            self.paused = False
        elif action == "return_to_dock":
            self.stops = [{"action": DOCK, "waypoint": self.dock}]
        self._changes += 1
        logger.info("%s: action %s", self.code, action)

    # --- The program ----------------------------------------------------------------------

    def _run(self) -> Program:
        while True:
            if self.paused:
                self._set(status="paused", mode="idle")
                yield Until(lambda: not self.paused)
                continue
            stop = self._next_stop()
            if stop is None:
                yield from self._idle()
            elif self.waypoint != stop["waypoint"]:
                yield from self._hop_towards(stop["waypoint"])
            else:
                yield from self._serve(stop)

    def _next_stop(self) -> dict | None:
        return self.stops[0] if self.stops else None

    def _idle(self) -> Program:
        at_dock = self.waypoint == self.dock
        self._set(status="charging" if at_dock else "idle", mode="charging" if at_dock else "idle")
        changes = self._changes
        yield Until(lambda: self._changes != changes)

    def _hop_towards(self, target: str) -> Program:
        hop = self._hop(target)
        if hop is None:
            yield from self._unreachable(target)
        elif hop.kind == "edge":
            yield from self._drive(hop.target)
        elif hop.kind == "guarded":
            yield from self._pass(hop)
        else:
            yield from self._ride(hop)

    def _on_map_version(self, version: int) -> None:
        self._map_wanted = version

    def _map_adopt(self) -> None:
        """Drive on the newest map from here on, if it has this waypoint (a robot is never
        handed a new map in the middle of a hop)."""
        wanted = self._map_wanted
        if self.maps is None or wanted is None or wanted == self.map_version or self._motion:
            return
        loaded = self.maps(wanted)
        if loaded is None or self.waypoint not in loaded[0].waypoints:
            return
        self.map, self.router = loaded
        self._edges = edge_index(self.map)
        self.map_version = wanted
        logger.info("%s: now on map version %d", self.code, wanted)

    def _hop(self, target: str) -> _Hop | None:
        """The next hop of the shortest path from here to `target` on the robot's own map.

        Plans' `via` points are not needed: with its own map the robot finds the same rides.
        """
        self._map_adopt()
        path = self.router.leg(self.waypoint, target).path
        if len(path) < 2:
            return None
        edge = self._edges.get((path[0], path[1]))
        if edge is None:
            elevator = self._elevator_between(path[0], path[1])
            floor = self.map.waypoints[path[1]].floor
            return _Hop("ride", path[1], resource=elevator, to_floor=floor)
        if edge.guarded_by is None:
            return _Hop("edge", path[1])
        passage = [path[1]]
        for a, b in zip(path[1:], path[2:], strict=False):
            following = self._edges.get((a, b))
            if following is None or following.guarded_by != edge.guarded_by:
                break
            passage.append(b)
        return _Hop("guarded", passage[-1], resource=edge.guarded_by, path=passage)

    def _elevator_between(self, a: str, b: str) -> str:
        for code, stops in self.map.elevator_stops.items():
            if a in stops.values() and b in stops.values():
                return code
        raise LookupError(f"no edge and no elevator between {a} and {b}")

    def _drive(self, target: str, *, status: str = "moving") -> Program:
        edge = self._edges[(self.waypoint, target)]
        seconds = edge.length / self.map.robot_speed
        self._set(status=status, mode="moving")
        self._motion = _Motion(self.waypoint, target, self._time, self._time + seconds)
        yield Sleep(seconds)
        self._motion = None
        self.waypoint = target
        self.stats.distance += edge.length
        self.stats.moving += seconds

    def _pass(self, hop: _Hop) -> Program:
        """A door or corridor: wait for the grant, enter, pass, release on the far side."""
        grant = yield from self._acquire(hop.resource, None)
        if grant is None:
            return
        self._event("resource_entered", resource=hop.resource)
        for target in hop.path:
            yield from self._drive(target, status="in_resource")
        self._event("resource_released", resource=hop.resource)
        logger.info("%s: passed %s", self.code, hop.resource)

    def _ride(self, hop: _Hop) -> Program:
        """An elevator: wait for the grant, announce boarding, ride offline, release."""
        grant = yield from self._acquire(hop.resource, hop.to_floor)
        if grant is None:
            return
        entered = self._event("resource_entered", resource=hop.resource)
        self._inside, self._exit = hop.resource, None
        self._set(status="in_resource", mode="idle")
        yield Until(lambda: self.client.delivered(entered))  # the cabin may have no network
        elevator = self.map.resources[hop.resource]
        logger.info("%s: rides %s to %s", self.code, hop.resource, hop.to_floor)
        self.riding = True
        self._set(mode="riding")
        self.battery = max(self.battery - self.behaviour.drain_per_ride, 0.0)
        self.lowest_battery = min(self.lowest_battery, self.battery)
        out, seconds = yield from self._ride_to(elevator, hop.target)
        self.riding = False
        self.waypoint = out
        self.stats.riding += seconds
        self.stats.rides += 1
        if out != hop.target:
            logger.info("%s: got out of %s at %s", self.code, hop.resource, out)
        self._inside, self._exit = None, None
        self._event("resource_released", resource=hop.resource)
        self._set(status="moving", mode="idle")

    def _ride_to(self, elevator, target: str) -> Generator[Sleep, None, tuple[str, float]]:
        """Ride floor by floor towards `target`, or to where an `elevator_exit` heard on the way
        says; (the lobby got out at, seconds ridden)."""
        level, ridden, out = self._level(self.waypoint), 0.0, None
        while True:
            if out is None:  # decided once: the car's next floor stays the one it was
                out = self._exit_lobby(elevator.code, level, target, moving=ridden > 0)
            goal = out or target
            if self._level(goal) == level:
                return goal, ridden
            if not ridden:  # the doors close and the car sets off
                ridden = elevator.overhead_seconds
                yield Sleep(elevator.overhead_seconds)
                continue
            yield Sleep(elevator.seconds_per_floor)
            ridden += elevator.seconds_per_floor
            level += 1 if self._level(goal) > level else -1

    def _exit_lobby(self, elevator: str, level: int, target: str, *, moving: bool) -> str | None:
        """Where an `elevator_exit` says to get out: its waypoint, or without one (the server
        does not drive the lift) the car's next floor towards `target` (this one, if the car
        has not set off)."""
        if self._exit is None:
            return None
        if self._exit.get("waypoint") in self.map.waypoints:
            return self._exit["waypoint"]
        stops = self.map.elevator_stops.get(elevator, {})
        step = 1 if self._level(target) > level else -1
        levels = sorted({self._level(lobby) for lobby in stops.values()}, reverse=step < 0)
        ahead = [n for n in levels if (n - level) * step > 0] if moving else [level]
        wanted = ahead[0] if ahead else level
        return next(lobby for lobby in stops.values() if self._level(lobby) == wanted)

    def _acquire(
        self, resource: str, to_floor: str | None
    ) -> Generator[Sleep | Until, None, dict | None]:
        """Ask for `resource` here and wait, queued, for the grant; None if the robot's route
        no longer needs it (a newer plan): then it is released, and the caller re-plans.

        A newer plan that still goes through the same resource keeps the robot's place in the
        queue (a changed elevator destination is sent as a new acquire of the same lease).
        """
        requests = {self._request("acquire", resource, to_floor=to_floor)}
        self._set(status="waiting_resource", mode="idle")
        while True:
            changes = self._changes
            yield Until(
                lambda changes=changes: self._granted_or_changed(resource, requests, changes)
            )
            grant = self._grant(resource, requests)
            if grant is not None:
                del self._grants[resource]
                if _expired(grant):  # arrived too late: ask again
                    requests.add(self._request("acquire", resource, to_floor=to_floor))
                    continue
                return grant
            need = self._resource_needed()
            if need is not None and need[0] == resource:
                if need[1] != to_floor:
                    to_floor = need[1]
                    requests.add(self._request("acquire", resource, to_floor=to_floor))
                continue
            self._request("release", resource)
            return None

    def _granted_or_changed(self, resource: str, requests: set[str], changes: int) -> bool:
        return self._grant(resource, requests) is not None or self._changes != changes

    def _grant(self, resource: str, requests: set[str]) -> dict | None:
        grant = self._grants.get(resource)
        return grant if grant is not None and grant.get("request") in requests else None

    def _resource_needed(self) -> tuple[str, str | None] | None:
        """The resource (and elevator floor) the next hop of the current plan needs, if any."""
        stop = self._next_stop()
        if self.paused or stop is None or stop["waypoint"] == self.waypoint:
            return None
        hop = self._hop(stop["waypoint"])
        if hop is None or hop.kind == "edge":
            return None
        return hop.resource, hop.to_floor

    def _serve(self, stop: dict) -> Program:
        action = stop["action"]
        if action == DOCK:
            if stop is self.stops[-1]:
                self.stops.remove(stop)
                logger.info("%s: docked at %s", self.code, self.waypoint)
                return
            # A dock stop with stops after it (a refuge in a fire alarm): wait there for the
            # next plan, which the rest of the route then follows.
            yield from self._idle()
            return
        task, index = stop["task"], stop["stop"]
        self._event("arrived", task=task, stop=index)
        self._set(status="waiting_load" if action == PICKUP else "waiting_unload", mode="idle")
        yield Sleep(self.rng.uniform(*self.behaviour.staff_delay))
        if not any(_key(s) == (task, index) for s in self.stops):
            return  # cancelled while the staff were coming: the new plan says what next
        secure = self.tasks.get(task, {}).get("secure")
        if action == PICKUP:
            self._load(task)
            self._event("loaded", task=task, stop=index, **self._lock(task, secure))
        elif secure and task in self.locked:
            opened = yield from self._open(task, secure)
            if opened is None:  # kept locked: the items stay on board for the operators
                self.stops = [s for s in self.stops if _key(s) != (task, index)]
                self.completed.add(task)
                return
            self._unload(task)
            self._event("unloaded", task=task, stop=index, **opened)
        else:
            self._unload(task)
            self._event("unloaded", task=task, stop=index)
        self.done.add((task, index))
        self.stops = [s for s in self.stops if _key(s) != (task, index)]
        if task not in self.completed and not any(s.get("task") == task for s in self.stops):
            self.completed.add(task)
            self.stats.completed += 1
            self._event("task_completed", task=task)
        logger.info("%s: %s %s at %s", self.code, _PAST[action], task, self.waypoint)

    def _lock(self, task: str, secure: dict | None) -> dict:
        """Lock a secure delivery's items in a free lockable compartment; the event's fields."""
        if not secure:
            return {}
        free = [code for code in self.lockable if code not in self.locked.values()]
        if not free:  # the server sent it to a robot without a free lock: report it plainly
            logger.error("%s: no free lockable compartment for %s", self.code, task)
            return {}
        self.locked[task] = free[0]
        return {"compartment": free[0], "opened_with": "staff"}

    def _open(self, task: str, secure: dict) -> Program:
        """The recipient types PINs until one opens the compartment or the robot locks it.
        Returns the `unloaded` event's fields, or None after compartment_locked."""
        compartment, known = self.locked[task], self.pins(task)
        badge = self.badges(self.waypoint)
        if badge is not None and self.rng.random() < self.behaviour.badge_share:
            yield Sleep(self.behaviour.pin_seconds / 4)
            holder = badge_check(badge, secure)  # on the robot, offline
            if holder is not None:
                del self.locked[task]
                return {"compartment": compartment, "opened_with": "badge", "opened_by": holder}
        attempts = int(secure.get("max_attempts", 3))
        for wrong in range(attempts):
            yield Sleep(self.behaviour.pin_seconds)
            mistyped = wrong == 0 and self.rng.random() < self.behaviour.wrong_pin
            typed = None if mistyped else known
            if typed is not None and pin_check(typed, secure):
                del self.locked[task]
                fields = {"compartment": compartment, "opened_with": "pin"}
                return {**fields, "failed_attempts": wrong}
        self._event(
            "compartment_locked", task=task, compartment=compartment, failed_attempts=attempts
        )
        logger.warning("%s: %s kept locked in %s after wrong PINs", self.code, task, compartment)
        return None

    def _load(self, task: str) -> None:
        pickups = [s for s in self.stops if s.get("task") == task and s["action"] == PICKUP]
        dropoffs = [s for s in self.stops if s.get("task") == task and s["action"] == DROPOFF]
        items = len(dropoffs) if len(pickups) == 1 else 1  # one-to-many: one item per drop-off
        self.on_board[task] = self.on_board.get(task, 0) + max(items, 1)
        self.stats.loaded += 1

    def _unload(self, task: str) -> None:
        dropoffs = [s for s in self.stops if s.get("task") == task and s["action"] == DROPOFF]
        left = self.on_board.get(task, 0) - 1 if len(dropoffs) > 1 else 0
        if left > 0:
            self.on_board[task] = left
        else:
            self.on_board.pop(task, None)
        self.stats.unloaded += 1

    def _unreachable(self, target: str) -> Program:
        """A stop the robot's map cannot reach: report the task failed and drop its stops."""
        stop = self.stops[0]
        task = stop.get("task")
        logger.error("%s: cannot reach %s from %s", self.code, target, self.waypoint)
        if task:
            self._event("task_failed", task=task, reason=f"no route to {target}")
            self.completed.add(task)
        self.stops = [s for s in self.stops if s.get("task") != task or task is None]
        if stop in self.stops:
            self.stops.remove(stop)
        yield Sleep(0.0)

    # --- Reporting ------------------------------------------------------------------------

    def _event(self, type: str, **fields) -> str:
        event_id = self.client.event(type, **fields)
        self.log.append({"id": event_id, "type": type, **fields})
        self.urgent = True
        return event_id

    def _request(self, type: str, resource: str, *, to_floor: str | None = None) -> str:
        if type == "acquire":
            request_id = self.client.acquire(resource, to_floor=to_floor)
            logger.info("%s: asks for %s at %s", self.code, resource, self.waypoint)
        else:
            request_id = self.client.release(resource)
        self.log.append({"id": request_id, "request": type, "resource": resource})
        self.urgent = True
        return request_id

    def _set(self, *, status: str | None = None, mode: str | None = None) -> None:
        if mode is not None and mode != self._mode:
            self._account(self._time)
            self._mode = mode
        if status is not None:
            self.status = status

    def _account(self, until: float) -> None:
        """Battery up to `until`, by what the robot has been doing since the last account."""
        seconds = until - self._accounted
        if seconds <= 0:
            return
        self._accounted = until
        b = self.behaviour
        if self._mode == "moving" and b.drain_per_metre is not None:
            self.battery -= b.drain_per_metre * self.map.robot_speed * seconds
        elif self._mode == "moving":
            self.battery -= b.drain_moving * seconds
        elif self._mode == "charging":
            self.battery = min(1.0, self.battery + b.charge_rate * seconds)
        elif self._mode == "idle":
            self.battery -= b.drain_idle * seconds
        self.battery = max(self.battery, 0.0)
        self.lowest_battery = min(self.lowest_battery, self.battery)

    def _position(self, now: float) -> tuple[float, float, float]:
        motion = self._motion
        if motion is None:
            here = self.map.waypoints[self.waypoint]
            return here.x, here.y, 0.0
        a, b = self.map.waypoints[motion.source], self.map.waypoints[motion.target]
        span = motion.ends - motion.started
        share = min(max((now - motion.started) / span, 0.0), 1.0) if span > 0 else 1.0
        heading = math.atan2(b.y - a.y, b.x - a.x)
        return a.x + (b.x - a.x) * share, a.y + (b.y - a.y) * share, heading

    def _level(self, waypoint: str) -> int:
        return self.map.waypoints[waypoint].level


_PAST = {PICKUP: "loaded", DROPOFF: "unloaded"}


def _key(stop: dict) -> tuple[str, int] | None:
    return (stop["task"], stop["stop"]) if stop.get("task") else None


def _describe(stops: list[dict]) -> str:
    return ", ".join(f"{s['action']} {s.get('task', '')} {s['waypoint']}".strip() for s in stops)


def _expired(grant: dict) -> bool:
    """A grant whose expires_at passed (by this robot's clock) was passed on to the next."""
    expires = grant.get("expires_at")
    if not expires:
        return False
    moment = datetime.fromisoformat(expires.replace("Z", "+00:00"))
    return moment <= datetime.now(UTC)


# --- The loop: heartbeats on the real clock, motion on the simulated one -----------------------


class RobotLoop:
    """Drives one SimRobot and its client: call step(now) repeatedly, `now` in real seconds
    (time.monotonic, or a virtual clock); it returns how long to wait before the next call.

    A heartbeat goes out every heartbeat_interval, at once when the push channel woke the
    client, and soon (urgent_gap) when the robot has something new to say (an event or a
    resource request), as a robot waiting at an elevator would.
    """

    def __init__(self, robot: SimRobot, *, urgent_gap: float = 0.05):
        self.robot = robot
        self.client = robot.client
        self.urgent_gap = urgent_gap
        self.next_beat = 0.0
        self.last_beat = -math.inf
        self.refused = 0

    def step(self, now: float) -> float:
        robot, client = self.robot, self.client
        robot.advance()
        # Something new to say goes out soon, unless the robot knows it has no network (the
        # regular heartbeats still try: that is how it finds the network again).
        urgent = robot.urgent and robot.connected() and now - self.last_beat >= self.urgent_gap
        if now >= self.next_beat or client.wake.is_set() or urgent:
            self._beat(now)
            robot.advance()
        wait = self.next_beat - now
        timer = robot.next_timer()
        if timer is not None:
            wait = min(wait, timer / robot.clock.speedup)
        if robot.urgent and robot.connected():
            wait = min(wait, self.urgent_gap)
        return max(wait, 0.0)

    def _beat(self, now: float) -> None:
        self.client.wake.clear()
        self.robot.urgent = False
        self.robot.report()
        try:
            self.client.heartbeat()
        except RefusedError as refused:
            self.refused += 1
            logger.error("%s: heartbeat refused: %s", self.robot.code, refused)
            self.client.drop_refused(refused)
        self.last_beat = now
        self.next_beat = now + self.client.heartbeat_interval
