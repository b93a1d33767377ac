"""Extension points: how a lower layer hands work to the layers above it without importing them.

A layer that must call up (the heartbeat hands robot events to the resource controller and the
scheduler) declares a Hook in its own `hooks.py` and calls it. The receivers of every hook are
connected in one place, hospital_delivery/extensions.py, in the order they run; nothing else
connects them. A receiver may raise to refuse what happened (a heartbeat receiver raises
boards.services.HeartbeatRejected): the exception reaches the caller, whose transaction then
rolls back, and the receivers after it are not called.
"""

from collections.abc import Callable, Iterator
from contextlib import contextmanager


class Hook:
    """A named extension point: receivers called in the order they were connected."""

    def __init__(self, name: str, arguments: str):
        self.name = name
        self.arguments = arguments  # what every receiver is called with, for the reader
        self._receivers: tuple[Callable[..., None], ...] = ()

    def connect(self, *receivers: Callable[..., None]) -> None:
        """Set the receivers, in order (hospital_delivery/extensions.py, at start-up)."""
        self._receivers = receivers

    @property
    def receivers(self) -> tuple[Callable[..., None], ...]:
        return self._receivers

    @contextmanager
    def watched_by(self, receiver: Callable[..., None]) -> Iterator[None]:
        """Call `receiver` too, last, while the block runs: for tests that watch a hook."""
        connected = self._receivers
        self._receivers = (*connected, receiver)
        try:
            yield
        finally:
            self._receivers = connected

    def __call__(self, **arguments) -> None:
        for receiver in self._receivers:
            receiver(**arguments)

    def __repr__(self) -> str:
        names = ", ".join(f"{r.__module__}.{r.__qualname__}" for r in self._receivers)
        return f"<Hook {self.name}({self.arguments}) -> [{names}]>"
