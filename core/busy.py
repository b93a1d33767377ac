"""How busy this process is serving requests: the share of wall time in which it was serving at
least one, over windows of about WINDOW_SECONDS (core.middleware.BusyMiddleware times every
request, pages and API as well as heartbeats, since they all share the workers).

A gunicorn sync worker serves one request at a time and all workers take connections from one
socket, so each worker's share is a sample of the pool's: near 1 when requests wait for a
worker (the pool is saturated), lower the more often a worker waits for a request. No shared
state, no query: two clock readings and a few additions per request.

Part of each request's cost is outside what a middleware can time: gunicorn reading the request
and closing the connection, Django's handler around the middleware. Saturated, a worker goes
from one request to the next after just that, and that time would read as idle, holding the
share under the controller's 80 % while requests queue. So the shortest pause between two
requests seen so far, but never more than the window's mean time serving one request, counts
as busy in every pause: it is what the worker needs between requests however busy it is (a
worker serving one robot a second does not look busy for it). It was not the reason why, with
1,000 robots and the default ceiling, bench/heartbeat.py saw heartbeats wait 0.85 s at the
ceiling's 4.5 s while the share read under 80 % (2026-11-24, the same with and without it, and
with the controller judging from the ceiling's interval; README). Two later runs did not
reproduce that queue (p50 101 and 8.9 ms, README); where those requests waited is not known.

The share reads about 83 % at most here (the rest is what no middleware times), near what the
pool takes as past it (bench/heartbeat.py, 2026-11-25). The queue tells the two apart:
connections waiting on the listening sockets for a worker to accept them, a few below what the
pool takes, hundreds past it, growing. Under gunicorn (hospital_delivery/gunicorn_hooks
hands each worker's sockets over, listeners_watch) every request's start reads the length of
that queue from the kernel (TCP_INFO of a listening socket, Linux), and the window carries its
mean; without them (tests, runserver) it is None.
"""

import math
import socket
import struct
import threading
import time
from dataclasses import dataclass

WINDOW_SECONDS = 2.0
# Linux's struct tcp_info: for a listening socket, tcpi_unacked (after 8 bytes of flags and
# four 32-bit fields) is the number of connections waiting to be accepted.
_TCP_INFO_WAITING = 24


@dataclass(frozen=True)
class Window:
    start: float  # clock times (time.monotonic)
    end: float
    share: float  # of the window's wall time spent serving, 0 to 1
    waiting: float | None = None  # connections waiting for a worker, mean at requests' starts


class BusyMeter:
    """Busy time summed while at least one request is in progress (threads may overlap), a
    window closed at the end of the first request that finishes WINDOW_SECONDS after it began."""

    def __init__(self, *, clock=time.monotonic, window: float = WINDOW_SECONDS):
        self.clock, self.window = clock, window
        self._lock = threading.Lock()
        self.forget()

    def forget(self) -> None:
        """Start measuring afresh (tests)."""
        self.last: Window | None = None  # the latest closed window
        self._serving = 0
        self._since = 0.0  # when this process began serving without a pause
        self._start: float | None = None  # of the current window
        self._busy = 0.0  # seconds served in the current window
        self._idle_since: float | None = None  # when the last pause between requests began
        self._pauses: list[float] = []  # seconds of each pause in the current window
        self._served = 0  # requests finished in the current window
        self._shortest = math.inf  # the shortest pause ever seen
        self._waiting = 0  # connections waiting, summed over the window's requests' starts
        self._sampled = 0  # requests whose start read it
        self.listeners: list[socket.socket] = []  # sockets whose queue is read (listeners_watch)

    def listeners_watch(self, listeners: list[socket.socket]) -> None:
        """Read the queue of these listening sockets at every request's start (Linux only)."""
        if hasattr(socket, "TCP_INFO"):
            self.listeners = list(listeners)

    def started(self) -> None:
        with self._lock:
            now = self.clock()
            if self._start is None:
                self._start = now
            if not self._serving:
                self._since = now
                if self._idle_since is not None:
                    self._pauses.append(now - self._idle_since)
                    self._shortest = min(self._shortest, now - self._idle_since)
            self._serving += 1
            if self.listeners:
                self._waiting += sum(_waiting(listener) for listener in self.listeners)
                self._sampled += 1

    def finished(self) -> None:
        with self._lock:
            now = self.clock()
            self._serving -= 1
            self._served += 1
            if self._serving:
                return
            self._busy += now - self._since
            self._idle_since = now
            if now - self._start >= self.window:
                share = (self._busy + self._overhead()) / (now - self._start)
                waiting = self._waiting / self._sampled if self._sampled else None
                self.last = Window(self._start, now, min(share, 1.0), waiting)
                self._start, self._busy, self._pauses, self._served = now, 0.0, [], 0
                self._waiting = self._sampled = 0

    def _overhead(self) -> float:
        """Seconds of the window's pauses spent on the work between requests (module doc)."""
        between = min(self._shortest, self._busy / self._served)
        return sum(min(pause, between) for pause in self._pauses)


def _waiting(listener: socket.socket) -> int:
    """Connections waiting on a listening socket for accept() (0 once it is closed)."""
    try:
        info = listener.getsockopt(socket.IPPROTO_TCP, socket.TCP_INFO, 32)
    except OSError:
        return 0
    return struct.unpack_from("I", info, _TCP_INFO_WAITING)[0]


busy = BusyMeter()
