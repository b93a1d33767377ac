"""Delivery requests as a hospital makes them, through the public task API only.

`POST /api/v1/tasks/` with a staff user's token (`Authorization: Bearer <token>`), exactly as
a hospital system or the nurses' page would. Nothing here reads the server's database.

What gets requested (the source paper, section 2.2: laboratory samples, medicines, medical
supplies; one-to-one and one-to-many):

| kind | from | to | share |
|---|---|---|---|
| samples | a ward | the laboratory's sample reception | 45 % (morning peak) |
| urgent samples | a ward, urgent | the laboratory | 5 % |
| STAT samples | a ward, STAT (due in 20 min by default) | the laboratory | 3 % |
| medication | the pharmacy | a ward | 20 % |
| medication round | the pharmacy | 2-3 wards (one-to-many) | 8 % (and at fixed times) |
| sample kits | the laboratory's pickup counter | a ward | 10 % |
| supplies | central supply | a ward | 12 % |

Stations are recognised by their names on the map (a site without a laboratory or pharmacy
gets random station pairs for the missing kinds).
"""

from __future__ import annotations

import logging
import random
import threading
from collections.abc import Callable
from dataclasses import dataclass

import requests

from robots.router import STATION, SiteMap

logger = logging.getLogger("robotsim.traffic")


@dataclass(frozen=True)
class Stations:
    """A site's stations by role, recognised by name."""

    wards: tuple[str, ...]
    lab_drop: str
    lab_pickup: str
    pharmacy: str
    supply: str
    names: dict[str, str]

    @classmethod
    def of(cls, site_map: SiteMap) -> Stations:
        names = {
            code: (wp.name or code) for code, wp in site_map.waypoints.items() if wp.kind == STATION
        }
        if len(names) < 2:
            raise ValueError("the site needs at least two stations for deliveries")
        lower = {code: f"{code} {name}".lower() for code, name in names.items()}

        def first(*words, avoid=()) -> str | None:
            return next(
                (
                    code
                    for code, text in lower.items()
                    if all(w in text for w in words) and not any(a in text for a in avoid)
                ),
                None,
            )

        lab_drop = first("sample") or first("lab", avoid=("pickup", "result")) or first("lab")
        lab_pickup = first("lab", "pickup") or first("lab", "result") or lab_drop
        pharmacy = first("pharm")
        supply = first("supply")
        special = {lab_drop, lab_pickup, pharmacy, supply}
        wards = tuple(code for code in names if code not in special) or tuple(names)
        fallback = wards[0]
        return cls(
            wards=wards,
            lab_drop=lab_drop or fallback,
            lab_pickup=lab_pickup or lab_drop or fallback,
            pharmacy=pharmacy or fallback,
            supply=supply or fallback,
            names=names,
        )


# kind -> (share of random requests, contents)
KINDS = {
    "samples": (0.45, "Blood samples"),
    "urgent": (0.05, "Urgent blood gas samples"),
    "medication": (0.20, "Medication"),
    "round": (0.08, "Medication round"),
    "kits": (0.10, "Sample collection kits"),
    "supplies": (0.12, "Dressings and IV supplies"),
    "stat": (0.03, "STAT blood gas samples"),
}
PRIORITIES = {"urgent": "urgent", "stat": "stat"}  # kind -> priority; every other is routine


def request_body(kind: str, stations: Stations, rng: random.Random) -> dict:
    """One request of `kind` as the task API takes it."""
    wards = stations.wards
    if kind in ("samples", "urgent", "stat"):
        pickups, dropoffs = [rng.choice(wards)], [stations.lab_drop]
    elif kind == "medication":
        pickups, dropoffs = [stations.pharmacy], [rng.choice(wards)]
    elif kind == "round":
        count = min(len(wards), rng.choice((2, 3)))
        pickups, dropoffs = [stations.pharmacy], rng.sample(wards, count)
    elif kind == "kits":
        pickups, dropoffs = [stations.lab_pickup], [rng.choice(wards)]
    elif kind == "supplies":
        pickups, dropoffs = [stations.supply], [rng.choice(wards)]
    else:
        raise ValueError(f"unknown kind {kind!r}")
    dropoffs = [code for code in dropoffs if code not in pickups]
    if not dropoffs:  # a small site where the roles coincide: any other station
        dropoffs = [rng.choice([code for code in stations.names if code not in pickups])]
    return {
        "sender": stations.names[pickups[0]],
        "receiver": stations.names[dropoffs[0]] if len(dropoffs) == 1 else "Wards",
        "contents": KINDS[kind][1],
        "priority": PRIORITIES.get(kind, "routine"),
        "pickups": pickups,
        "dropoffs": dropoffs,
    }


def random_kind(rng: random.Random) -> str:
    kinds = list(KINDS)
    return rng.choices(kinds, weights=[KINDS[k][0] for k in kinds])[0]


# --- A hospital day ----------------------------------------------------------------------------

# Requests per hour of each kind, by hour of the day (site local time), 08:00-20:00: the
# morning blood-draw round fills the laboratory's peak; medication rounds leave the pharmacy
# at fixed times as one-to-many deliveries.
DAY_RATES = {
    "samples": {8: 10, 9: 10, 10: 5, 11: 5, **dict.fromkeys(range(12, 20), 3)},
    "urgent": dict.fromkeys(range(8, 20), 0.5),
    "medication": dict.fromkeys(range(8, 20), 2),
    "kits": dict.fromkeys(range(8, 20), 1),
    "supplies": {**dict.fromkeys(range(8, 20), 1), 14: 2, 15: 2},
    "stat": dict.fromkeys(range(8, 20), 0.5),
}
ROUND_TIMES = ((9, 0), (13, 0), (17, 0))  # medication rounds: two one-to-many tasks each


def day_requests(
    stations: Stations, *, seed: int, hours: tuple[int, int] = (8, 20), scale: float = 1.0
) -> list[tuple[float, dict]]:
    """A day's requests as (seconds after `hours[0]`:00, API body), in time order.

    The same seed gives the same stream; `scale` multiplies every rate.
    """
    rng = random.Random(seed)
    start, end = hours
    stream = []
    for kind, rates in DAY_RATES.items():
        for hour in range(start, end):
            rate = rates.get(hour, 0) * scale
            at = 0.0
            while rate > 0:
                at += rng.expovariate(rate / 3600)
                if at >= 3600:
                    break
                stream.append(((hour - start) * 3600 + at, request_body(kind, stations, rng)))
    for hour, minute in ROUND_TIMES:
        if start <= hour < end:
            for n in range(max(1, round(2 * scale))):
                moment = (hour - start) * 3600 + minute * 60 + n * 60
                stream.append((moment, request_body("round", stations, rng)))
    return sorted(stream, key=lambda item: item[0])


# --- Posting ------------------------------------------------------------------------------------


class HttpTaskApi:
    """The task API over HTTP with a staff user's token."""

    def __init__(self, server_url: str, token: str, *, timeout: float = 10.0):
        self.url = f"{server_url.rstrip('/')}/api/v1/tasks/"
        self.session = requests.Session()
        self.session.headers["Authorization"] = f"Bearer {token}"
        self.timeout = timeout

    def post(self, body: dict) -> tuple[int, dict]:
        response = self.session.post(self.url, json=body, timeout=self.timeout)
        try:
            return response.status_code, response.json()
        except ValueError:
            return response.status_code, {"error": response.text[:200]}


class HttpMapSource:
    """A published map version's site file from the map API (maps/views.py), with a staff
    user's token: how the simulated robots fetch the map a heartbeat answer announces. Real
    robots fetch theirs however their integrators chose; None on any failure (tried again at
    the robot's next waypoint)."""

    def __init__(self, server_url: str, token: str, site: str, *, timeout: float = 10.0):
        self.url = f"{server_url.rstrip('/')}/api/v1/maps/{site}/versions/"
        self.session = requests.Session()
        self.session.headers["Authorization"] = f"Bearer {token}"
        self.timeout = timeout

    def __call__(self, version: int) -> dict | None:
        try:
            response = self.session.get(f"{self.url}{version}", timeout=self.timeout)
            document = response.json().get("document") if response.status_code == 200 else None
        except (requests.RequestException, ValueError, AttributeError):
            return None
        return document if isinstance(document, dict) else None


class TrafficGenerator:
    """Random requests at `rate` per simulated hour (a Poisson stream), for a live fleet."""

    def __init__(
        self,
        api,
        stations: Stations,
        *,
        rate: float,
        rng: random.Random,
        speedup: float = 1.0,
        wait: Callable[[float], bool] | None = None,
        secure_share: float = 0.0,
    ):
        if rate <= 0:
            raise ValueError("rate must be positive")
        self.api = api
        self.stations = stations
        self.rate = rate
        self.rng = rng
        self.speedup = speedup
        self.posted: list[str] = []  # task codes
        # Medication goes secure this often; each one's PIN is told to its recipient, as a
        # nurse would hand it on (the simulated robots' staff look it up here).
        self.secure_share = secure_share
        self.pins: dict[str, str] = {}
        self.failed = 0
        self._wait = wait

    def run(self, stop: threading.Event) -> None:
        wait = self._wait or (lambda seconds: stop.wait(seconds))
        while not stop.is_set():
            if wait(self.rng.expovariate(self.rate / 3600) / self.speedup):
                return
            self.post_one()

    def post_one(self) -> str | None:
        kind = random_kind(self.rng)
        body = request_body(kind, self.stations, self.rng)
        if kind == "medication" and self.rng.random() < self.secure_share:
            body["secure"] = True
        try:
            status, reply = self.api.post(body)
        except requests.RequestException as exc:
            self.failed += 1
            logger.warning("traffic: request not sent: %s", exc)
            return None
        if status != 201:
            self.failed += 1
            logger.warning("traffic: request refused (%s): %s", status, reply)
            return None
        self.posted.append(reply["code"])
        if "pin" in reply:
            self.pins[reply["code"]] = reply["pin"]
        logger.info(
            "traffic: %s %s, %s -> %s",
            reply["code"],
            body["contents"],
            "+".join(body["pickups"]),
            "+".join(body["dropoffs"]),
        )
        return reply["code"]
