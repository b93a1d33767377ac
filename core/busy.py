"""How loaded this process's pool of web workers is: the requests it serves and the connections
waiting for a worker, over windows of about WINDOW_SECONDS (core.middleware.BusyMiddleware
counts every request, pages and API as well as heartbeats, since they all share the workers).

gunicorn's sync workers all take connections from the same listening sockets, one at a time.
Where the kernel lets us read the queue on those sockets (Linux: TCP_INFO of a listening
socket; hospital_delivery/gunicorn_hooks hands the sockets over, listeners_watch), every
request's start reads how many connections are still waiting to be accepted. The fewest read
in a window tells whether the queue ever emptied in it: 0 if a worker found it empty once, more
when requests arrived faster than the pool served them for the whole window (a standing queue).
While the queue stands, what this process serves is its share of the pool's capacity, whatever
the machine: the heartbeat cadence learns it there (robots/cadence.py), with the processor time
the process used (time.process_time, every thread of it), since what a request costs depends on
what it is.

The share of wall time spent inside requests does not tell that: part of each request's cost is
outside what a middleware can time (gunicorn reading the request, and lingering after the answer
until the client closes, up to 2 s: 40 % of a worker's time with 300 robots sent straight to
gunicorn on a 2-core machine, py-spy), so the share read 29 % while 997 connections waited, and the
cadence shortened the interval in the middle of an overload (bench/heartbeat.py --timeline).

Two clock readings, one getsockopt per socket and a few additions per request; no query.
"""

import multiprocessing
import os
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
    served: int  # requests the pool finished in the window (this process, without gunicorn)
    cpu: float = 0.0  # seconds of processor time the pool used in the window (likewise)
    waiting: float | None = None  # connections waiting for a worker, mean at requests' starts
    # The fewest waiting at any request's start: 0 once the queue emptied in the window, more
    # when it never did. None where the queue is not read (no gunicorn sockets: tests, runserver).
    waiting_least: int | None = None
    pool: int | None = None  # processes taking connections from the same sockets, this one too

    @property
    def seconds(self) -> float:
        return self.end - self.start

    @property
    def rate(self) -> float:
        """Requests a second the pool served."""
        return self.served / self.seconds if self.seconds > 0 else 0.0

    @property
    def queue_stood(self) -> bool:
        """Whether connections waited for a worker throughout the window."""
        return bool(self.waiting_least)


class Tally:
    """Requests served and processor seconds used: by this process, or (shared) by every
    process forked after it was made, in memory they share."""

    def __init__(self, *, shared: bool = False):
        if shared:
            self._values, self._lock = multiprocessing.RawArray("d", 2), multiprocessing.Lock()
        else:
            self._values, self._lock = [0.0, 0.0], threading.Lock()

    def add(self, *, served: int, cpu: float) -> None:
        with self._lock:
            self._values[0] += served
            self._values[1] += cpu

    def read(self) -> tuple[int, float]:
        with self._lock:
            return int(self._values[0]), self._values[1]


class BusyMeter:
    """Requests counted and the queue read at each start; a window closed at the end of the
    first request that finishes WINDOW_SECONDS after it began.

    Requests and processor time are this process's, or the whole pool's once the gunicorn
    master shared them before forking its workers (pool_share): each process's own window
    scaled by the pool's size read the pool's rate from 93 to 200 a second from one window to
    the next while it served about 180 (bench/heartbeat.py)."""

    def __init__(
        self, *, clock=time.monotonic, cpu=time.process_time, window: float = WINDOW_SECONDS
    ):
        self.clock, self.cpu, self.window = clock, cpu, window
        self._lock = threading.Lock()
        self.listeners: list[socket.socket] = []  # sockets whose queue is read (listeners_watch)
        self.pool: int | None = None
        self.tally = Tally()
        self._cpu_told = cpu()  # this process's processor time already added to the tally
        # A forked worker's processor time starts again from 0.
        os.register_at_fork(after_in_child=lambda: setattr(self, "_cpu_told", self.cpu()))
        self.forget()

    def forget(self) -> None:
        """Start measuring afresh (tests)."""
        self.last: Window | None = None  # the latest closed window
        self._start: float | None = None  # of the current window
        self._tallied = (0, 0.0)  # the tally then
        self._waiting = 0  # connections waiting, summed over the window's requests' starts
        self._waiting_least: int | None = None
        self._sampled = 0  # requests whose start read the queue

    def pool_share(self) -> None:
        """Count requests and processor time for every process forked from now on (gunicorn's
        master, before it forks its workers)."""
        self.tally = Tally(shared=True)

    def listeners_watch(self, listeners: list[socket.socket], *, pool: int) -> None:
        """Read the queue of these listening sockets at every request's start (Linux only);
        `pool`: the processes that take connections from them, this one included."""
        if hasattr(socket, "TCP_INFO"):
            self.listeners, self.pool = list(listeners), pool

    def started(self) -> None:
        waiting = sum(_waiting(listener) for listener in self.listeners)
        with self._lock:
            if self._start is None:
                self._start, self._tallied = self.clock(), self.tally.read()
            if self.listeners:
                self._waiting += waiting
                self._sampled += 1
                least = self._waiting_least
                self._waiting_least = waiting if least is None else min(least, waiting)

    def finished(self) -> None:
        with self._lock:
            now, cpu = self.clock(), self.cpu()
            self.tally.add(served=1, cpu=cpu - self._cpu_told)
            self._cpu_told = cpu
            if now - self._start >= self.window:
                tallied = self.tally.read()
                self.last = self._closed(now, tallied)
                self._start, self._tallied = now, tallied
                self._waiting = self._sampled = 0
                self._waiting_least = None

    def _closed(self, now: float, tallied: tuple[int, float]) -> Window:
        served, cpu = tallied[0] - self._tallied[0], tallied[1] - self._tallied[1]
        if not self._sampled:
            return Window(self._start, now, served, cpu)
        return Window(
            self._start,
            now,
            served,
            cpu,
            waiting=self._waiting / self._sampled,
            waiting_least=self._waiting_least,
            pool=self.pool,
        )


def _waiting(listener: socket.socket) -> int:
    """Connections waiting on a listening socket for accept() (0 once it is closed)."""
    try:
        info = listener.getsockopt(socket.IPPROTO_TCP, socket.TCP_INFO, 32)
    except OSError:
        return 0
    return struct.unpack_from("I", info, _TCP_INFO_WAITING)[0]


busy = BusyMeter()
