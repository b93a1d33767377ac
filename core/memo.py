"""Reads done once per unit of work (a heartbeat, a delivery request, an allocation batch)
rather than once per row.

A unit of work opens a scope inside its transaction (`with memo.scope():`); within it,
`memo.once(key, read)` reads the first time and hands the same result back after. Outside any
scope it simply reads. The scope closes with the unit of work, so nothing is kept past the
transaction that read it, and what is kept must be something that unit does not change: the
webhook subscriptions of a site, asked once for every task status change, are the reason
(an allocation batch of 100 tasks asked 100 times, bench/latency.py's burst).
"""

from collections.abc import Callable, Hashable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import TypeVar

T = TypeVar("T")

_KEPT: ContextVar[dict | None] = ContextVar("memo", default=None)


@contextmanager
def scope() -> Iterator[None]:
    """Keep what `once` reads until the block ends; a scope inside another is the outer one."""
    if _KEPT.get() is not None:
        yield
        return
    token = _KEPT.set({})
    try:
        yield
    finally:
        _KEPT.reset(token)


def once(key: Hashable, read: Callable[[], T]) -> T:
    """read(), or what it returned the first time in this scope for the same key."""
    kept = _KEPT.get()
    if kept is None:
        return read()
    if key not in kept:
        kept[key] = read()
    return kept[key]
