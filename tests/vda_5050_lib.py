"""Third-party VDA 5050 2.0 vehicles: the npm package vda-5050-lib (pinned in package.json,
installed by scripts/lib.sh ensure_node_packages), its AgvController with its
VirtualAgvAdapter, run by node from tests/vda_5050_lib_vehicles.js on the tests' Mosquitto."""

import json
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from robots.models import Robot
from tests import servers

# What the library's virtual vehicle needs from a site (the integrators' VDA 5050 page):
# its pick and drop take only stationType "floor..." and loadType "EPAL"; it wants the 1.1
# field name in instantActions; it keeps its map after a lift ride unless told by initPosition.
LIB_OPTIONS = {
    "pick": {"stationType": "floor", "loadType": "EPAL"},
    "drop": {"stationType": "floor", "loadType": "EPAL"},
    "quirks": ["instant_actions_field", "init_position_after_lift"],
}


@dataclass
class LibVehicle:
    robot: Robot
    state_interval: float  # seconds, the library's publishStateInterval

    def entry(self) -> dict:
        dock = self.robot.dock
        return {
            "manufacturer": self.robot.manufacturer,
            "serialNumber": self.robot.serial_number,
            "publishStateInterval": int(self.state_interval * 1000),
            "position": {
                "x": dock.x,
                "y": dock.y,
                "theta": 0,
                "mapId": dock.floor.code,
                "lastNodeId": dock.code,
            },
        }


class LibVehicles:
    """The vehicles in one node process; `time_lapse` speeds their driving and actions up."""

    def __init__(self, vehicles: list[LibVehicle], *, broker, interface: str, time_lapse=25):
        self.vehicles, self.broker, self.interface = vehicles, broker, interface
        self.time_lapse = time_lapse
        self.process = None
        self._dir = tempfile.TemporaryDirectory(prefix="hd-vdalib-")

    def __enter__(self):
        config = Path(self._dir.name) / "vehicles.json"
        config.write_text(
            json.dumps(
                {
                    "broker": f"mqtt://{self.broker[0]}:{self.broker[1]}",
                    "interface": self.interface,
                    "timeLapse": self.time_lapse,
                    "vehicles": [vehicle.entry() for vehicle in self.vehicles],
                }
            )
        )
        command = ["node", str(servers.REPO / "tests" / "vda_5050_lib_vehicles.js"), str(config)]
        self.process = subprocess.Popen(
            command, cwd=servers.REPO, stdout=subprocess.PIPE, text=True
        )
        deadline = time.monotonic() + 30
        line = self.process.stdout.readline()  # "ready", or "" if it died
        if line.strip() != "ready" or time.monotonic() > deadline:
            self.process.kill()
            raise RuntimeError(f"the vda-5050-lib vehicles did not start ({line!r})")
        return self

    def __exit__(self, *exc):
        self.process.terminate()
        try:
            self.process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self._dir.cleanup()
