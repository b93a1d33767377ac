"""How busy this process is serving requests: the share of wall time in which it was serving at
least one, over windows of about WINDOW_SECONDS (core.middleware.BusyMiddleware times every
request, pages and API as well as heartbeats, since they all share the workers).

A gunicorn sync worker serves one request at a time and all workers take connections from one
socket, so each worker's share is a sample of the pool's: near 1 when requests wait for a
worker (the pool is saturated), lower the more often a worker waits for a request. No shared
state, no query: two clock readings and a few additions per request.
"""

import threading
import time
from dataclasses import dataclass

WINDOW_SECONDS = 2.0


@dataclass(frozen=True)
class Window:
    start: float  # clock times (time.monotonic)
    end: float
    share: float  # of the window's wall time spent serving, 0 to 1


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

    def started(self) -> None:
        with self._lock:
            now = self.clock()
            if self._start is None:
                self._start = now
            if not self._serving:
                self._since = now
            self._serving += 1

    def finished(self) -> None:
        with self._lock:
            now = self.clock()
            self._serving -= 1
            if self._serving:
                return
            self._busy += now - self._since
            if now - self._start >= self.window:
                self.last = Window(self._start, now, min(self._busy / (now - self._start), 1.0))
                self._start, self._busy = now, 0.0


busy = BusyMeter()
