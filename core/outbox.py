"""Redis-bound side effects leave the thread that asks for them.

Wake-ups, live page events and Celery messages are courtesies: the database is the record, and
the protocol's heartbeats and the sweeps find whatever one of them failed to say. So no request
may wait for Redis, least of all one holding a robot's row lock (an early wake-up is sent from
inside that transaction): a Redis that accepts connections and never answers would otherwise
hold every heartbeat of that robot, and on SQLite the whole database, for the client's timeout.

`send_soon` puts a callable on a queue that one daemon thread per process works through in
order. If Redis stalls, the queue waits there; past MAX_PENDING the newest is dropped (and
logged), which costs at most one heartbeat interval of delay (robots) or a re-read (pages).
With settings.OUTBOX_THREAD off (the test process) it runs the callable at once instead.

The thread is a daemon, so it would die with a process that exits right after queueing (a
management command: `manage.py robot_token` closing the old token's push sockets); at exit
the process waits up to EXIT_DRAIN_SECONDS for what is queued to be sent.
"""

import atexit
import logging
import os
import queue
import threading
import time
from collections.abc import Callable

from django.conf import settings

logger = logging.getLogger(__name__)

MAX_PENDING = 10_000
EXIT_DRAIN_SECONDS = 5

_lock = threading.Lock()
_state: dict = {"pid": None, "queue": None}


def send_soon(send: Callable[[], None], *, what: str) -> None:
    """Run `send` on the outbox thread; failures are logged, never raised."""
    if not getattr(settings, "OUTBOX_THREAD", True):
        _run(send, what)
        return
    try:
        _queue().put_nowait((send, what))
    except queue.Full:
        logger.warning("outbox full (%d waiting): %s dropped", MAX_PENDING, what)


def drain(timeout: float) -> bool:
    """Wait until everything queued so far is sent; False if `timeout` seconds pass first."""
    pending = _state["queue"] if _state["pid"] == os.getpid() else None
    deadline = time.monotonic() + timeout
    while pending is not None and pending.unfinished_tasks:
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.005)
    return True


def _queue() -> queue.Queue:
    """This process's queue and thread, started on first use (and again in a forked child)."""
    if _state["pid"] != os.getpid():
        with _lock:
            if _state["pid"] != os.getpid():
                pending: queue.Queue = queue.Queue(maxsize=MAX_PENDING)
                threading.Thread(target=_work, args=(pending,), name="outbox", daemon=True).start()
                _state.update(pid=os.getpid(), queue=pending)
                atexit.register(drain, EXIT_DRAIN_SECONDS)
    return _state["queue"]


def _work(pending: queue.Queue) -> None:
    while True:
        send, what = pending.get()
        try:
            _run(send, what)
        finally:
            pending.task_done()


def _run(send: Callable[[], None], what: str) -> None:
    try:
        send()
    except Exception as failed:
        logger.warning("%s failed: %r", what, failed)
