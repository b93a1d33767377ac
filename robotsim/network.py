"""A lossy robot network, as a transport wrapper for RobotClient (no Django, no server access).

Hospital Wi-Fi as the source paper describes it (section 2.1): no connection inside elevator
cabins, a dead spot at every access-point handover, and otherwise an unreliable link. The
wrapper decides, per heartbeat, whether

* there is no network at all (`connected()` says so: the robot is in a cabin or in a dead
  zone): the heartbeat fails at once, as a robot's connect() would;
* the request is lost on the way (the server never sees it);
* the response is lost on the way back (the server applied the heartbeat, the robot cannot
  know: it keeps and resends everything, which the server must de-duplicate);
* the request is duplicated: a copy reaches the server again later (a retransmission or a
  proxy retry), after the robot may have sent newer heartbeats, so the server sees it late
  and out of order; its answer goes nowhere;
* both directions are delayed by a random amount.

All randomness comes from the `rng` given, so a seeded run loses the same heartbeats.
"""

import logging
import queue
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from robotsim.client import HttpTransport, TransportError

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class NetworkModel:
    """Probabilities per heartbeat, delays in real seconds, dead zones as waypoint codes."""

    request_loss: float = 0.0
    response_loss: float = 0.0
    duplicate: float = 0.0
    delay: tuple[float, float] = (0.0, 0.0)  # one way, uniform between the two
    duplicate_delay: tuple[float, float] = (0.2, 2.0)  # how late a duplicate arrives
    dead_zones: frozenset[str] = frozenset()

    def __post_init__(self):
        for name in ("request_loss", "response_loss", "duplicate"):
            if not 0.0 <= getattr(self, name) < 1.0:
                raise ValueError(f"{name} must be in [0, 1)")
        for name in ("delay", "duplicate_delay"):
            low, high = getattr(self, name)
            if not 0.0 <= low <= high:
                raise ValueError(f"{name} must be 0 <= low <= high")


@dataclass
class NetworkStats:
    sent: int = 0
    offline: int = 0
    requests_lost: int = 0
    responses_lost: int = 0
    duplicated: int = 0

    def __str__(self) -> str:
        return (
            f"{self.sent} sent, {self.offline} without network, {self.requests_lost} requests "
            f"and {self.responses_lost} responses lost, {self.duplicated} duplicated"
        )


class LossyTransport:
    """Wraps a transport (HttpTransport by default) with a NetworkModel.

    `connected` is asked before every heartbeat: the simulated robot answers False while it
    rides an elevator or stands in a dead zone.
    """

    def __init__(
        self,
        model: NetworkModel,
        *,
        rng: random.Random,
        connected: Callable[[], bool] = lambda: True,
        inner=None,
        sleep: Callable[[float], None] = time.sleep,
        duplicates_via=None,
    ):
        self.model = model
        self.rng = rng
        self.connected = connected
        self.inner = inner or HttpTransport(timeout=3.0)
        self.sleep = sleep
        self.duplicates_via = duplicates_via  # the transport of late copies; default: HTTP
        self.stats = NetworkStats()
        self._duplicates: DuplicateSender | None = None

    def post(self, url: str, body: dict, headers: dict) -> tuple[int, dict | str]:
        if not self.connected():
            self.stats.offline += 1
            raise TransportError("no network here")
        self.stats.sent += 1
        self._delay()
        if self._happens(self.model.request_loss):
            self.stats.requests_lost += 1
            raise TransportError("request lost")
        if self._happens(self.model.duplicate):
            self.stats.duplicated += 1
            self._duplicate_later(url, body, headers)
        answer = self.inner.post(url, body, headers)
        self._delay()
        if self._happens(self.model.response_loss):
            self.stats.responses_lost += 1
            raise TransportError("response lost")
        return answer

    def close(self) -> None:
        if self._duplicates is not None:
            self._duplicates.close()

    def _happens(self, probability: float) -> bool:
        return probability > 0 and self.rng.random() < probability

    def _delay(self) -> None:
        low, high = self.model.delay
        if high > 0:
            self.sleep(self.rng.uniform(low, high))

    def _duplicate_later(self, url: str, body: dict, headers: dict) -> None:
        if self._duplicates is None:
            self._duplicates = DuplicateSender(self.duplicates_via or HttpTransport(timeout=3.0))
        after = self.rng.uniform(*self.model.duplicate_delay)
        self._duplicates.send(time.monotonic() + after, url, dict(body), dict(headers))


@dataclass(order=True)
class _Copy:
    due: float
    number: int
    url: str = field(compare=False)
    body: dict = field(compare=False)
    headers: dict = field(compare=False)


class DuplicateSender:
    """Sends late copies of heartbeats from a thread of its own; their answers are dropped."""

    def __init__(self, transport):
        self._queue: queue.PriorityQueue[_Copy] = queue.PriorityQueue()
        self._numbers = iter(range(1, 2**62))
        self._transport = transport
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._run, name="duplicates", daemon=True)
        self._thread.start()

    def send(self, due: float, url: str, body: dict, headers: dict) -> None:
        self._queue.put(_Copy(due, next(self._numbers), url, body, headers))

    def close(self) -> None:
        self._closed.set()
        self._queue.put(_Copy(0.0, 0, "", {}, {}))  # wake the thread
        self._thread.join(timeout=5)

    def _run(self) -> None:
        while not self._closed.is_set():
            copy = self._queue.get()
            wait = copy.due - time.monotonic()
            if wait > 0:
                self._queue.put(copy)
                self._closed.wait(min(wait, 0.2))
                continue
            if copy.url:
                self._post(copy)

    def _post(self, copy: _Copy) -> None:
        try:
            self._transport.post(copy.url, copy.body, copy.headers)
        except TransportError as exc:
            logger.debug("duplicate heartbeat not delivered: %s", exc)
