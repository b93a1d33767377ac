"""A simulated fleet against a live server: N robots (a thread each, plus one for its push
channel) and, optionally, random delivery traffic through the task API.

Each robot knows only its map (the site file), its dock, its token and the server's URLs. Motion
runs on a simulated clock `speedup` times faster than real time; heartbeats are real HTTP at the
server's heartbeat_interval, and the server's timeouts are real time. So with a speed-up an
elevator ride keeps a robot offline for (overhead + floors × s/floor) / speedup real seconds.
"""

from __future__ import annotations

import json
import logging
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from robots.router import Router, SiteMap, site_map_from_file
from robotsim.client import RobotClient, listen_for_wakes
from robotsim.network import LossyTransport, NetworkModel, NetworkStats
from robotsim.simulator import Behaviour, RealClock, RobotLoop, SimRobot
from robotsim.traffic import HttpTaskApi, Stations, TrafficGenerator

logger = logging.getLogger("robotsim")

NO_DEAD_ZONE_KINDS = ("station", "dock", "resource_wait")  # robots wait there


@dataclass(frozen=True)
class RobotSpec:
    code: str
    token: str
    dock: str


@dataclass(frozen=True)
class FleetConfig:
    server_url: str
    site: dict  # the site file, parsed
    robots: tuple[RobotSpec, ...]
    speedup: float = 1.0
    network: NetworkModel = field(default_factory=NetworkModel)
    behaviour: Behaviour = field(default_factory=Behaviour)
    seed: int = 0
    ws_url: str | None = None  # the push channel's base URL; None: heartbeats only
    traffic_rate: float = 0.0  # deliveries per simulated hour
    traffic_token: str | None = None
    secure_share: float = 0.0  # of the medication deliveries, secure (locked, PIN)
    badges: dict[str, str] = field(default_factory=dict)  # station -> a unit user's badge id
    # The site file of a map version the server announces (map_version), however the robots
    # fetch it; None: they keep the map they were given.
    map_source: Callable[[int], dict | None] | None = None


def fleet_file_read(path: str | Path) -> dict:
    """var/fleet.json as written by `manage.py demo_setup`."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


class Fleet:
    """Build with a FleetConfig; start() it, stop() it (or run(stop) until an Event is set)."""

    def __init__(self, config: FleetConfig):
        self.config = config
        self.site_map = site_map_from_file(config.site)
        self._check_dead_zones(config.network.dead_zones)
        self.clock = RealClock(config.speedup)
        self.router = Router(self.site_map)  # shared: its searches are cached per source
        self._maps: dict[int, tuple[SiteMap, Router]] = {}  # announced versions, loaded once
        self._maps_lock = threading.Lock()
        self.traffic = self._traffic()
        self.robots = [self._robot(spec) for spec in config.robots]
        self.loops = [RobotLoop(robot) for robot in self.robots]
        self.errors: list[str] = []  # robots whose program crashed
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def _robot(self, spec: RobotSpec) -> SimRobot:
        seed = self.config.seed
        transport = LossyTransport(
            self.config.network, rng=random.Random(f"{seed}-net-{spec.code}")
        )
        client = RobotClient(
            server_url=self.config.server_url,
            robot=spec.code,
            token=spec.token,
            transport=transport,
        )
        robot = SimRobot(
            client=client,
            site_map=self.site_map,
            dock=spec.dock,
            clock=self.clock,
            rng=random.Random(f"{seed}-robot-{spec.code}"),
            behaviour=self.config.behaviour,
            router=self.router,
            dead_zones=self.config.network.dead_zones,
            compartments=self._compartments(spec.code),
            pins=self.traffic.pins.get if self.traffic else (lambda task: None),
            badges=self.config.badges.get,
            maps=self._map_of if self.config.map_source else None,
        )
        transport.connected = robot.connected
        return robot

    def _map_of(self, version: int) -> tuple[SiteMap, Router] | None:
        """Map version `version` and its router, shared by the fleet, fetched once."""
        with self._maps_lock:
            if version not in self._maps:
                document = self.config.map_source(version)
                if document is None:
                    return None
                site_map = site_map_from_file(document)
                self._maps[version] = (site_map, Router(site_map))
            return self._maps[version]

    def _compartments(self, code: str) -> list[dict]:
        """The robot's compartments as the site file declares them (none: an older robot)."""
        robots = {robot.get("code"): robot for robot in self.config.site.get("robots", [])}
        return list(robots.get(code, {}).get("compartments", []))

    def _traffic(self) -> TrafficGenerator | None:
        config = self.config
        if not config.traffic_rate:
            return None
        if not config.traffic_token:
            raise ValueError("traffic needs a staff user's API token")
        return TrafficGenerator(
            HttpTaskApi(config.server_url, config.traffic_token),
            Stations.of(self.site_map),
            rate=config.traffic_rate,
            rng=random.Random(f"{config.seed}-traffic"),
            speedup=config.speedup,
            secure_share=config.secure_share,
        )

    def _check_dead_zones(self, codes) -> None:
        for code in codes:
            waypoint = self.site_map.waypoints.get(code)
            if waypoint is None:
                raise ValueError(f"dead zone {code!r} is not a waypoint of the site")
            if waypoint.kind in NO_DEAD_ZONE_KINDS:
                raise ValueError(f"dead zone {code!r} is a {waypoint.kind}: robots wait there")

    # --- Running ----------------------------------------------------------------------------

    def start(self) -> None:
        for loop in self.loops:
            self._spawn(self._drive, loop, name=f"robot-{loop.robot.code}")
            if self.config.ws_url:
                spec = next(s for s in self.config.robots if s.code == loop.robot.code)
                self._spawn(self._listen, loop.client, spec.token, name=f"push-{spec.code}")
        if self.traffic is not None:
            self._spawn(self.traffic.run, self._stop, name="traffic")
        pushed = "with the push channel" if self.config.ws_url else "heartbeats only"
        logger.info(
            "fleet: %d robots at x%g, %s, %s",
            len(self.robots),
            self.config.speedup,
            pushed,
            f"traffic {self.config.traffic_rate:g}/h" if self.traffic else "no traffic",
        )

    def stop(self, timeout: float = 4.0) -> None:
        self._stop.set()
        for loop in self.loops:
            loop.client.wake.set()
        deadline = time.monotonic() + timeout
        for thread in self._threads:
            thread.join(timeout=max(deadline - time.monotonic(), 0.0))
        for robot in self.robots:
            robot.client.transport.close()

    def run(self, stop: threading.Event, *, status_every: float = 30.0) -> None:
        """start(), log a status line every `status_every` real seconds until `stop`, stop()."""
        self.start()
        try:
            while not stop.wait(status_every):
                logger.info("fleet: %s", self.status_line())
        finally:
            self.stop()

    def _spawn(self, target, *args, name: str) -> None:
        thread = threading.Thread(target=target, args=args, name=name, daemon=True)
        thread.start()
        self._threads.append(thread)

    def _drive(self, loop: RobotLoop) -> None:
        try:
            while not self._stop.is_set():
                wait = loop.step(time.monotonic())
                loop.client.wake.wait(min(wait, 0.5))
        except Exception:
            logger.exception("%s: the simulated robot crashed", loop.robot.code)
            self.errors.append(loop.robot.code)

    def _listen(self, client: RobotClient, token: str) -> None:
        listen_for_wakes(client, ws_url=self.config.ws_url, token=token, stop=self._stop)

    # --- Reading the results ----------------------------------------------------------------

    def status_line(self) -> str:
        return " | ".join(
            f"{r.code} {r.status} {r.waypoint} {r.battery:.0%} load {sum(r.on_board.values())}"
            for r in self.robots
        )

    def network_stats(self) -> NetworkStats:
        total = NetworkStats()
        for robot in self.robots:
            stats = robot.client.transport.stats
            for name in vars(total):
                setattr(total, name, getattr(total, name) + getattr(stats, name))
        return total

    def all_idle_at_dock(self) -> bool:
        """Every robot home with nothing to do and nothing left to tell the server."""
        return all(r.idle_at_dock and r.client.unsent == 0 for r in self.robots)
